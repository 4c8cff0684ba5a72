# Two commands do the whole set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
WBPOWER := $(VENV)/bin/wbpower

.PHONY: demo test lint bench sample-logs clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(WBPOWER) inspect sample_logs/
	$(WBPOWER) fit sample_logs/

test: $(VENV)/.installed
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q -n 2

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

bench: $(VENV)/.installed
	$(PY) benchmarks/run.py

# Regenerates sample_logs/ exactly as committed (see sample_logs/README.md).
sample-logs: $(VENV)/.installed
	rm -rf sample_logs.tmp && $(WBPOWER) simulate -o sample_logs.tmp --sample-period 0.001024 \
	  --columns power --compress gz --decimals 2 \
	  --effect decel_phase=0.3 --effect cruise_ripple=1.0 --seed 2015
	cp sample_logs/README.md sample_logs.tmp/ && rm -rf sample_logs && mv sample_logs.tmp sample_logs

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis
