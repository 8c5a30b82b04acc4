# The README's commands. Everything installs into .venv at the repository root.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: setup system-deps test test-fast demo regen bench bench-replay clean realdata accuracy mutants figures

setup: $(STAMP)

# The system packages the README's commands need (python3-venv before the venv exists, the C compilers
# the demo's verify uses, and for the tests valgrind, cmake, chromium...): installed with apt-get when
# missing, as on CI (.ci/run runs `make test`), so a fresh clone needs nothing installed by hand.
system-deps:
	bash .ci/system-deps

$(STAMP): pyproject.toml | system-deps
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,ulog,ardupilot,rosbag,netcdf,cfcheck]'
	touch $(STAMP)

# The suite runs on PYTEST_WORKERS processes (pytest-xdist, issue #34: CI has two cores). --dist loadfile
# gives each worker whole modules, so a module-scoped fixture or shared fit is computed in one process;
# --no-loadscope-reorder keeps the longest-first module order of tests/conftest.py (MODULE_SECONDS) so the
# workers finish together. PYTEST_WORKERS=0 runs serially in one process (make test PYTEST_WORKERS=0).
PYTEST_WORKERS ?= 2
PYTEST_PARALLEL := $(if $(filter 0,$(PYTEST_WORKERS)),,-n $(PYTEST_WORKERS) --dist loadfile --no-loadscope-reorder)
# Python's bytecode cache on, whatever the shell says: with PYTHONDONTWRITEBYTECODE set (this machine's and CI's
# environment), every `dobwind` child a test starts compiles the project's modules again (`dobwind check
# --no-selftest` 0.66 s without the cache, 0.59 s with it). Whole-suite runs on idle fresh clones (issue #34,
# docs/architecture.md) scatter by about 20 s either way, so the suite-level gain is not resolved by them.
# __pycache__ is ignored by git and by tests/test_isolation.py.
# OpenBLAS single-threaded (OPENBLAS_NUM_THREADS=1, inherited by every `dobwind` child): by default each process
# starts a BLAS thread per core, and with two workers on two cores their threads wait on each other. Two
# test_thrustscale runs side by side took 15-17 s each that way and 4.7 s each with one thread; alone, one
# process takes the same time either way (test_thrustscale and test_fieldcal, 15-17 s both ways).
PYTEST := env -u PYTHONDONTWRITEBYTECODE OPENBLAS_NUM_THREADS=1 $(BIN)/python -m pytest

test: system-deps $(STAMP)
	$(PYTEST) -q $(PYTEST_PARALLEL)

# The quick part of the suite (markers in tests/conftest.py): every package, no slow fit and no fuzz case.
test-fast: system-deps $(STAMP)
	$(PYTEST) -q $(PYTEST_PARALLEL) -m "not slow and not fuzz"

demo: $(STAMP)
	$(BIN)/dobwind demo -o out/demo

# Refresh the checked-in C for every airframe in airframes/ (tests fail while it is stale).
regen: $(STAMP)
	$(BIN)/python -m tools.regen

# docs/figures.md and its images, from the current code (tests/test_docfigures.py fails when stale).
figures: $(STAMP)
	$(BIN)/python -m tools.docfigures docs

# The M4F cycle estimate needs Unicorn (the bench extra); without it the column shows "-".
bench: $(STAMP)
	$(BIN)/pip install --quiet -e '.[bench]'
	$(BIN)/python -m benchmarks.bench

# Issue #13's replay goals: 1 h and 4 h logs at 100 Hz against a bare csv.reader pass (time, peak memory).
bench-replay: $(STAMP)
	$(BIN)/python -m benchmarks.bench_replay $(BENCH_REPLAY_ARGS)

clean:
	rm -rf $(VENV) out .pytest_cache

# Optional: the real Neural-Fly runs beside the checkout (never copied into the project).
realdata: $(STAMP)
	$(BIN)/python -m benchmarks.realdata

# Issue #12's generalization benchmark: six simulated vehicles x 2 seeds through the whole command-line
# workflow, a sample-rate study, and the real runs when present (4 min on 2 idle cores, 10-20 min when
# loaded). ACCURACY_ARGS=--quick: one seed, three vehicles; --random N: N random vehicles.
accuracy: $(STAMP)
	$(BIN)/python -m benchmarks.accuracy $(ACCURACY_ARGS)

# Issue #10/#16's mutation suite: single-point mutants of the generated C (both precisions) and of the
# model, each expected to be caught by verify, the self-test or the tests; exit 1 on a survivor, 2 when
# a mutant's anchor no longer matches (re-anchor in tools/mutant_table.py). About 20 min on a loaded 2-core machine.
mutants: $(STAMP)
	$(BIN)/python -m tools.mutants $(MUTANTS_ARGS)
