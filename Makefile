# sarcli: every target is a file target where it can be, so `make` re-runs only what is out of date.
# `make demo` and `make test` set up the virtual environment themselves (Python >= 3.11).

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
SAR    := $(BIN)/sar -q
OUT    := out
GOTCHA := ../shared/data/gotcha
PYTEST_WORKERS ?= 2

.PHONY: all setup demo test test-fast data bench gotcha clean distclean help

all: demo

help:
	@echo "make demo    set up $(VENV) and run the three-points pipeline into $(OUT)/"
	@echo "make test    set up $(VENV) and run the test suite"
	@echo "make data    regenerate data/synthetic/"
	@echo "make bench   run the benchmarks (ratios against baselines in the same run)"
	@echo "make gotcha  image the AFRL GOTCHA files in $(GOTCHA)"

# -- environment -------------------------------------------------------------------------------
$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

setup: $(VENV)/.installed

# -- tests ---------------------------------------------------------------------------------------
test: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) tests

test-fast: $(VENV)/.installed
	$(BIN)/python -m pytest -q -x tests

# -- demo: three points --------------------------------------------------------------------------
$(OUT)/three-points.h5: configs/three-points.yaml $(VENV)/.installed
	@mkdir -p $(OUT)
	$(SAR) simulate $< -o $@ --seed 1

demo: $(OUT)/three-points.h5
	$(BIN)/sar info $(OUT)/three-points.h5

# -- committed synthetic data (small) --------------------------------------------------------
data/synthetic/three-points-small.h5: configs/three-points.yaml $(VENV)/.installed
	$(BIN)/python scripts/make_synthetic.py data/synthetic

data: data/synthetic/three-points-small.h5

# -- benchmarks ----------------------------------------------------------------------------------
bench: $(VENV)/.installed
	@mkdir -p $(OUT)/bench
	@for b in bench/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(OUT)

distclean: clean
	rm -rf $(VENV) *.egg-info
