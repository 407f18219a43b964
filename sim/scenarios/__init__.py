"""Built-in scenarios: truth and measurement generators."""
