# The README's commands. Everything installs into .venv at the repository root.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: setup test demo regen bench clean realdata accuracy

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,ulog,ardupilot,rosbag]'
	touch $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

demo: $(STAMP)
	$(BIN)/dobwind demo -o out/demo

# Refresh the checked-in C for every airframe in airframes/ (tests fail while it is stale).
regen: $(STAMP)
	$(BIN)/python -m dobwind.codegen.regen

bench: $(STAMP)
	$(BIN)/python -m dobwind.harness.bench

clean:
	rm -rf $(VENV) out .pytest_cache

# Optional: the real Neural-Fly runs beside the checkout (never copied into the project).
realdata: $(STAMP)
	$(BIN)/python -m dobwind.harness.realdata

# Issue #12's generalization benchmark: six simulated vehicles x 2 seeds through the whole command-line
# workflow, plus the real runs when present (~25 min on 2 cores). ACCURACY_ARGS=--quick: under 5 min.
accuracy: $(STAMP)
	$(BIN)/python -m dobwind.accuracy $(ACCURACY_ARGS)
