"""Reports of runs and campaigns: figures in the form of Lubey & Ely's (2022) results and a Markdown summary."""
