"""The command line: the parser and dispatch (app.py), one module per command that has its own logic
(analyze, profile, demo, replaymany, campaign), and the help formatter.

``dobwind.cli:main`` is the console script (pyproject.toml), so ``main`` is re-exported here."""
from dobwind.cli.app import main

__all__ = ["main"]
