# Two commands do the whole set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
WBPOWER := $(VENV)/bin/wbpower

.PHONY: demo test lint bench sample-logs clean

# The oldest Python wbpower runs on (pyproject.toml: requires-python).
MIN_PYTHON ?= 3.11
# Succeeds in an interpreter new enough; else says which it is and what to do.
NEW_ENOUGH := import sys; need = tuple(map(int, "$(MIN_PYTHON)".split("."))); \
  sys.exit(0 if sys.version_info[:2] >= need else "wbpower needs Python >= $(MIN_PYTHON), " \
  + sys.executable + " is " + sys.version.split()[0] + " (give PYTHON=python3.11 or newer)")
# Overridable for tests/test_makefile.py (which must not download anything).
PIP_INSTALL ?= $(PY) -m pip install --quiet
VENV_FLAGS ?=

# The venv is rebuilt from scratch when it is not known good: its install never completed
# (no .installed: e.g. a `make demo PYTHON=python3.10` that failed half way), or its python
# does not run or is too old. The check of $(PY) runs on every make (about 20 ms), so even a
# venv marked installed but broken since is rebuilt, not used.
VENV_OK := $(shell $(PY) -c '$(NEW_ENOUGH)' >/dev/null 2>&1 && echo yes)

$(VENV)/.installed: pyproject.toml $(if $(VENV_OK),,venv-stale)
	@$(PYTHON) -c '$(NEW_ENOUGH)'
	@if [ ! -f $@ ] || ! $(PY) -c '$(NEW_ENOUGH)' >/dev/null 2>&1; then \
	  if [ -e $(VENV) ]; then echo "$(VENV) is incomplete or stale: building it again"; fi; \
	  rm -rf $(VENV); \
	fi
	@test -x $(PY) || $(PYTHON) -m venv $(VENV_FLAGS) $(VENV)
	$(PIP_INSTALL) --upgrade pip
	$(PIP_INSTALL) -e '.[dev]'
	touch $@

.PHONY: venv-stale

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
