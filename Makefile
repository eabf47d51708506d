# Every target creates the local virtual environment first (fresh machine: Python 3.11 + pip).
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed-stamp
OUT ?= hdrfringe-demo

.PHONY: install demo test lint bench bench-sweep clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e ".[dev]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/hdrfringe demo -o $(OUT) --force

test: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks
	$(VENV)/bin/pytest -n 2 --dist loadgroup -q

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks

bench: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_phase.py

bench-sweep: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_sweep.py

clean:
	rm -rf $(VENV) $(OUT)
