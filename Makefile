# The README's commands. Everything installs into .venv at the repository root.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: setup test demo regen bench bench-replay clean realdata accuracy mutants

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,ulog,ardupilot,rosbag,netcdf,cfcheck]'
	touch $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

demo: $(STAMP)
	$(BIN)/dobwind demo -o out/demo

# Refresh the checked-in C for every airframe in airframes/ (tests fail while it is stale).
regen: $(STAMP)
	$(BIN)/python -m dobwind.regen

# The M4F cycle estimate needs Unicorn (the bench extra); without it the column shows "-".
bench: $(STAMP)
	$(BIN)/pip install --quiet -e '.[bench]'
	$(BIN)/python -m dobwind.harness.bench

# Issue #13's replay goals: 1 h and 4 h logs at 100 Hz against a bare csv.reader pass (time, peak memory).
bench-replay: $(STAMP)
	$(BIN)/python -m dobwind.harness.bench_replay $(BENCH_REPLAY_ARGS)

clean:
	rm -rf $(VENV) out .pytest_cache

# Optional: the real Neural-Fly runs beside the checkout (never copied into the project).
realdata: $(STAMP)
	$(BIN)/python -m dobwind.realdata

# Issue #12's generalization benchmark: six simulated vehicles x 2 seeds through the whole command-line
# workflow, a sample-rate study, and the real runs when present (4 min on 2 idle cores, 10-20 min when
# loaded). ACCURACY_ARGS=--quick: one seed, three vehicles; --random N: N random vehicles.
accuracy: $(STAMP)
	$(BIN)/python -m dobwind.accuracy $(ACCURACY_ARGS)

# Issue #10/#16's mutation suite: single-point mutants of the generated C (both precisions) and of the
# model, each expected to be caught by verify, the self-test or the tests; exit 1 on a survivor, 2 when
# a mutant's anchor no longer matches (re-anchor in harness/mutant_table.py). About 20 min on a loaded 2-core machine.
mutants: $(STAMP)
	$(BIN)/python -m dobwind.harness.mutants $(MUTANTS_ARGS)
