# Two commands do the whole set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
WBPOWER := $(VENV)/bin/wbpower

.PHONY: demo test browser lint bench bench-jls sample-logs docs-figures clean

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
	@# ros, jls: the optional readers of bags and Joulescope recordings, tested by `make test`
	$(PIP_INSTALL) -e '.[dev,ros,jls]'
	@# an editable install compiles no bytecode, and where PYTHONDONTWRITEBYTECODE is set
	@# every start would compile wifibot_power again (~80 ms): compiled here, as pip does
	@# for a regular install (a module edited since is compiled from its source, as ever)
	$(PY) -m compileall -q wifibot_power
	touch $@

.PHONY: venv-stale

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(WBPOWER) inspect sample_logs/
	$(WBPOWER) fit sample_logs/
	$(WBPOWER) report sample_logs/ -o out/report
	@echo "open out/report/report.html in a browser (one file, works offline)"

# The suite takes ~4 min on 2 cores; a run still going after 30 min is hung (a deadlock in a
# C extension holds the GIL, so pytest-timeout's own thread cannot fire: tests/jlswriter.py)
# and is stopped, so that CI fails instead of waiting for ever.
test: $(VENV)/.installed browser
	$(VENV)/bin/ruff check .
	timeout -k 30 1800 $(PY) -m pytest -q -n 2

# What the browser test (tests/test_report_browser.py: report.html in headless Chromium)
# needs: selenium in the venv (the `browser` extra, ~45 MB with its dependencies), and
# Debian's chromium and chromium-driver (505 MB with their libraries on Debian 12), installed
# with apt where this runs as root with apt-get; elsewhere the test is skipped and says why.
# apt is given at most 5 + 10 minutes (a CI job never hangs on a slow mirror). Nothing else
# is fetched:
# selenium drives the system chromedriver, never downloads a browser of its own.
CHROMIUM_PACKAGES ?= chromium chromium-driver
browser: $(VENV)/.browser
	@if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "installing $(CHROMIUM_PACKAGES) with apt-get for the browser test"; \
	  (timeout 300 apt-get update -qq && DEBIAN_FRONTEND=noninteractive timeout 600 \
	    apt-get install -y -qq $(CHROMIUM_PACKAGES) >/dev/null) \
	  || echo "could not install $(CHROMIUM_PACKAGES): the browser test will be skipped"; \
	else echo "no chromium and chromedriver (and not root with apt-get): the browser test" \
	  "will be skipped"; fi

$(VENV)/.browser: $(VENV)/.installed
	$(PIP_INSTALL) -e '.[browser]'
	touch $@

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

# fit and diagnose beside a bare CSV parse on five shapes of log, and fit on 400 MB of free
# driving (the drive model, issue 25; written once by `wbpower simulate --drive free`, ~45 s of
# CPU) (docs/benchmarks.md): ~4 min on 2 idle cores once the corpora are built (measured
# 2026-11-28; far longer on a loaded machine); the corpora (~2.9 GB) go to
# $$WBPOWER_BENCH_CORPUS, else bench_corpus/.
# BENCH_ARGS: e.g. --quick, --shapes power,n6705, --repeats 5 (benchmarks/run.py --help).
BENCH_ARGS ?=
bench: $(VENV)/.installed
	$(PY) benchmarks/run.py $(BENCH_ARGS)
	$(MAKE) bench-jls

# a 100 M-sample Joulescope recording (828 MB, written once into the corpus folder) inspected
# and segmented: throughput, peak memory, energy against the full-rate sum (~1 min)
bench-jls: $(VENV)/.installed
	$(PY) benchmarks/jls_long.py

# Regenerates sample_logs/ exactly as committed (see sample_logs/README.md).
sample-logs: $(VENV)/.installed
	rm -rf sample_logs.tmp && $(WBPOWER) simulate -o sample_logs.tmp --sample-period 0.001024 \
	  --columns power --compress gz --decimals 2 \
	  --effect decel_phase=0.3 --effect cruise_ripple=1.0 --seed 2015
	cp sample_logs/README.md sample_logs.tmp/ && rm -rf sample_logs && mv sample_logs.tmp sample_logs

# The figures shown in README.md and docs/report.md: the reports of sample_logs/ and of the real
# N6705C export, and report.html in headless Chromium (Debian: apt-get install chromium).
FIGS := out/report/figures
docs-figures: $(VENV)/.installed
	$(WBPOWER) report sample_logs/ -o out/report
	-$(WBPOWER) report ../shared/real_logs/n6705c_dlog1.csv --supply-voltage 12.6 -o out/report-real
	mkdir -p docs/figures
	cp $(FIGS)/trace_v0.50_d10_s10_r1.png docs/figures/sample_trace.png
	for f in power_speed heldout_error findings figure5 figure7; do \
	  cp $(FIGS)/$$f.png docs/figures/sample_$$f.png; done
	cp out/report-real/figures/trace_n6705c_dlog1.png docs/figures/real_n6705c_trace.png
	rm -rf out/chromium-profile && chromium --headless --no-sandbox --disable-gpu \
	  --disable-background-networking --disable-component-update --disable-sync --no-first-run \
	  --user-data-dir=out/chromium-profile --hide-scrollbars --window-size=1280,2600 \
	  --screenshot=out/report_chromium.png file://$(CURDIR)/out/report/report.html
	$(PY) -c "from PIL import Image; im = Image.open('out/report_chromium.png').convert('RGB'); \
	  im.resize((640, 1300)).quantize(256).save('docs/figures/report_chromium.png', optimize=True)"
	@# the trace view, zoomed and with a selection: the browser test's own screenshots
	rm -rf out/explorer && WBPOWER_SCREENSHOTS=out/explorer $(PY) -m pytest -q -n 0 \
	  tests/test_report_browser.py
	for f in whole selection; do $(PY) -c "import sys; from PIL import Image; \
	  Image.open(sys.argv[1]).convert('RGB').quantize(256).save(sys.argv[2], optimize=True)" \
	  out/explorer/report_explorer_$$f.png docs/figures/report_explorer_$$f.png; done

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis
