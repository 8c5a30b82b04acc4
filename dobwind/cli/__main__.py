"""`python -m dobwind.cli ARGS`: the console script without its wrapper (the tests and benchmarks run it so)."""
from dobwind.cli.app import main

raise SystemExit(main())
