"""Built-in truth trajectories (``insight-approach``)."""
