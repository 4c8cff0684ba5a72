# Two commands do the whole set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
WBPOWER := $(VENV)/bin/wbpower

.PHONY: demo test lint bench sample-logs docs-figures clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

install: $(VENV)/.installed

demo: $(VENV)/.installed
	$(WBPOWER) inspect sample_logs/
	$(WBPOWER) fit sample_logs/
	$(WBPOWER) report sample_logs/ -o out/report
	@echo "open out/report/report.html in a browser (one file, works offline)"

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

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis
