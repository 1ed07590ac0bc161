# whiskercal: `make demo` runs the calibration pipeline on the digital twin, `make test` the tests.
# `make test-all` the whole suite. Each creates the virtual environment (.venv) on first use,
# with the tested versions (LOCK).

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
INSTALLED := $(VENV)/.installed
OUT ?= out/demo
# Exact versions of every package the suite passed with; pyproject.toml keeps the ranges.
LOCK ?= requirements.lock
LATEST_VENV ?= .venv-latest

.PHONY: setup test test-all test-latest lock demo walkthrough-figures bench docs firmware firmware-deps clean

setup: $(INSTALLED)

$(INSTALLED): pyproject.toml $(LOCK)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c $(LOCK) -e '.[dev]'
	# the numba kernels compiled once into their cache, not in every first test worker or fit
	$(PY) -m whiskercal.mechfit.kernels
	touch $@

# The fast tier (what a contributor runs many times a day): every test not marked slow, with
# line coverage of whiskercal/ against the floor in pyproject.toml ([tool.coverage.report]).
# worksteal: an idle worker takes queued tests from a busy one.
# One OpenBLAS kernel on every x86-64 CPU: the default fit's goldens (data/) are computed with
# Haswell's, and its joint fit stops elsewhere under another's (data/README.md).
export OPENBLAS_CORETYPE ?= Haswell
# A test run after the first reads its compiled test modules and whiskercal from __pycache__
# instead of compiling them again in every worker.
unexport PYTHONDONTWRITEBYTECODE
PYTEST := $(PY) -m pytest -n 2 --dist worksteal -q
test: $(INSTALLED)
	$(PYTEST) -m "not slow" --cov=whiskercal --cov-report=

# Everything: the slow family fits, the emulated firmware, the studies, the docs site, grbl when
# WHISKERCAL_GRBL_SRC names its source. .ci/run runs this, so what lands is checked whole.
test-all: $(INSTALLED)
	$(PYTEST) --cov=whiskercal --cov-report=

# The suite against the newest versions pyproject.toml allows, in a venv of their own (no lock).
test-latest:
	$(PYTHON) -m venv $(LATEST_VENV)
	$(LATEST_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST_VENV)/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e '.[dev]'
	$(LATEST_VENV)/bin/python -m pip freeze --exclude-editable
	$(LATEST_VENV)/bin/python -m pytest -n 2 --dist worksteal -q -p no:cov

# Write LOCK from the packages installed in VENV: after `make test-latest` passed,
# `make lock VENV=.venv-latest` makes the newest versions the tested ones.
lock:
	@test -x $(PY) || { echo "no $(PY): run make setup or make test-latest first" >&2; exit 1; }
	{ echo "# Tested versions of every package whiskercal and its tests install, as pip"; \
	  echo "# constraints: make setup installs with pip install -c $(LOCK) -e '.[dev]'."; \
	  echo "# Written by make lock; make test-latest tests the newest versions instead."; \
	  $(PY) -m pip freeze --exclude-editable; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)

demo: $(INSTALLED)
	OUT=$(OUT) PY=$(PY) bash scripts/demo.sh

# The tutorial's example outputs (docs/walkthrough.md) are what the demo printed.
walkthrough-figures: demo
	$(PY) scripts/docs_figures.py transcript $(OUT)

# The bench's JSON also refreshes the documentation's figure snapshots (docs/figures/*.json).
bench: $(INSTALLED)
	$(PY) -m whiskercal bench --out out/bench --force
	$(PY) -m whiskercal twin validate --json > out/bench/twin-validate.json
	for f in sensors/*.toml; do \
	  $(PY) -m whiskercal twin describe $$f --json > out/bench/twin-describe-$$(basename $$f .toml).json; \
	done
	$(PY) scripts/docs_figures.py snapshot out/bench

# The site (mkdocs-material) into build/site; --strict: a broken link or a missing page fails it.
docs: $(INSTALLED)
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict --quiet

clean:
	rm -rf out build .pytest_cache

# ---- firmware (firmware/Makefile has the details; docs/firmware.md the wiring and flashing) ----
.PHONY: firmware-host-test firmware-sim grbl-sim

firmware:
	$(MAKE) -C firmware avr

firmware-deps:
	apt-get update && apt-get install -y gcc-avr avr-libc arduino-core-avr simavr libsimavr-dev libelf-dev pkg-config g++ make

firmware-host-test:
	$(MAKE) -C firmware host-test

# The .hex images on simavr with emulated parts (sim://NAME/sensor?firmware=avr, docs/firmware.md)
firmware-sim:
	$(MAKE) -C firmware sim

# ---- recorded datasets (data/README.md) ----
.PHONY: regress record-data

regress: $(INSTALLED)
	$(PY) -m whiskercal regress data

record-data: $(INSTALLED)
	$(PY) scripts/record_data.py

# Stock grbl 1.1h (WHISKERCAL_GRBL_SRC=checkout of gnea/grbl, not part of this repository) built for
# the emulator: sim://NAME/stage?firmware=grbl[&homing=xy[&origin=set]] (docs/firmware.md)
grbl-sim:
	$(MAKE) -C firmware grbl
