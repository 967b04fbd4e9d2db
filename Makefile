# Two commands on a fresh machine:
#   make demo   set up what the demo needs (core + viz), then run the built-in example (Figure 1)
#   make test   set up everything (every extra: peers, boxmot, fleet, ros, dev), then run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# stamps: everything installed / the demo's part installed (the first implies the second)
STAMP      := $(VENV)/.installed
DEMO_STAMP := $(VENV)/.installed-demo

.PHONY: setup demo test bench benchmark clean

$(BIN)/pip:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

$(DEMO_STAMP): pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --quiet -e '.[viz]'
	touch $(DEMO_STAMP)

$(STAMP): pyproject.toml | $(BIN)/pip
	$(BIN)/pip install --quiet -e '.[dev,viz,benchmark,boxmot,fleet,ros]'
	touch $(STAMP) $(DEMO_STAMP)

setup: $(STAMP)

demo: $(DEMO_STAMP)
	$(BIN)/sensemaking demo --output-dir demo-output

# the package, benchmarks/ and tests/ are ruff-clean, the package mypy-clean (pyproject.toml), then every test
test: $(STAMP)
	$(BIN)/ruff check src benchmarks tests
	$(BIN)/ruff format --check src benchmarks tests
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/scalability.py

# every benchmark in ../shared/data, ours beside SORT/ByteTrack/OC-SORT; writes docs/BENCHMARKS.md,
# docs/benchmarks.json and docs/PARAMETERS.md (the project's pages: benchmarks/benchmark_report.py)
benchmark: $(STAMP)
	$(BIN)/python benchmarks/benchmark_report.py

clean:
	rm -rf $(VENV) demo-output build *.egg-info src/*.egg-info
