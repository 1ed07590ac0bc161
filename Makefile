# whiskercal: `make demo` runs the calibration pipeline on the digital twin, `make test` the tests.
# Both create the virtual environment (.venv) on first use.

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
INSTALLED := $(VENV)/.installed
OUT ?= out/demo

.PHONY: setup test demo bench firmware firmware-deps clean

setup: $(INSTALLED)

$(INSTALLED): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

test: $(INSTALLED)
	$(PY) -m pytest -n 2 -q

demo: $(INSTALLED)
	OUT=$(OUT) PY=$(PY) bash scripts/demo.sh

bench: $(INSTALLED)
	$(PY) -m whiskercal bench --out out/bench

clean:
	rm -rf out build .pytest_cache

# ---- firmware (firmware/Makefile has the details; docs/firmware.md the wiring and flashing) ----
.PHONY: firmware-host-test

firmware:
	$(MAKE) -C firmware avr

firmware-deps:
	apt-get update && apt-get install -y gcc-avr avr-libc arduino-core-avr simavr libsimavr-dev g++ make

firmware-host-test:
	$(MAKE) -C firmware host-test

# ---- recorded datasets (data/README.md) ----
.PHONY: regress record-data

regress: $(INSTALLED)
	$(PY) -m whiskercal regress data

record-data: $(INSTALLED)
	$(PY) scripts/record_data.py
