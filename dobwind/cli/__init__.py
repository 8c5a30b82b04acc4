"""The command line: the top-level parser and dispatch (app.py), one module per command (check.py,
fit.py, replay.py, ...: each with ``add`` and ``run``), the many-log pool (replaymany, campaign), the
shared help texts (common) and the help formatter.

``dobwind.cli:main`` is the console script (pyproject.toml), so ``main`` is re-exported here."""
from dobwind.cli.app import main

__all__ = ["main"]
