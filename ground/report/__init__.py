"""Reports of runs and campaigns: figures in the form of seed 001's results and a Markdown summary."""
