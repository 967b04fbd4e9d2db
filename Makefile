# Two commands on a fresh machine:
#   make demo   set up, then run the built-in example (Figure 1 of the paper)
#   make test   set up, then run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup demo test bench benchmark clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev,viz,benchmark,boxmot,fleet,ros]'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/sensemaking demo --output-dir demo-output

# the package and benchmarks/ are ruff-clean, the package mypy-clean (pyproject.toml), then every test
test: $(STAMP)
	$(BIN)/ruff check src benchmarks
	$(BIN)/ruff format --check src benchmarks
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/scalability.py

# every benchmark in ../shared/data, ours beside SORT/ByteTrack/OC-SORT; writes docs/BENCHMARKS.md
benchmark: $(STAMP)
	$(BIN)/sensemaking benchmark

clean:
	rm -rf $(VENV) demo-output build *.egg-info src/*.egg-info
