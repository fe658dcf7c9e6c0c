# sarcli: every target is a file target where it can be, so `make` re-runs only what is out of date.
# `make demo` and `make test` set up the virtual environment themselves (Python >= 3.11).

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
SAR    := $(BIN)/sar -q
OUT    := out
# a local copy of the AFRL GOTCHA pass files: make gotcha GOTCHA=DIR, or $$SARCLI_GOTCHA_DIR (docs/conventions.md)
GOTCHA ?= $(or $(SARCLI_GOTCHA_DIR),../shared/data/gotcha)
PYTEST_WORKERS ?= 2

.PHONY: all setup demo test test-fast data bench gotcha paper tutorial stability clean distclean help

all: demo

help:
	@echo "make demo    set up $(VENV) and run the three-points pipeline into $(OUT)/"
	@echo "make test    set up $(VENV) and run the test suite"
	@echo "make data    regenerate data/synthetic/"
	@echo "make bench   run the benchmarks (ratios against baselines in the same run)"
	@echo "make gotcha  image the AFRL GOTCHA files in $(GOTCHA)"
	@echo "make paper   regenerate the paper's figures into $(OUT)/paper and docs/paper.md"
	@echo "make tutorial regenerate docs/tutorial.md and its pictures from the demo's outputs"
	@echo "make stability regenerate docs/stability.md from the stability cases in tests/stability/"

# -- environment -------------------------------------------------------------------------------
# sarcli's kernels (src/native/) are C++17 compiled when the package is installed. The venv holds
# the build requirements too, so `pip install -e .` runs without build isolation and an edit to a
# kernel rebuilds only what changed (in build/): `make setup` after editing src/native.
NATIVE := CMakeLists.txt $(wildcard src/native/*.cpp src/native/*.hpp src/native/*/*.cpp src/native/*/*.hpp)
CXX ?= c++

# a new subpackage (its __init__.py newer than the install) re-installs: the editable install maps each
# module to its file, and a module that became a package (sarcli/regularize.py -> sarcli/regularize/)
# is not found again until then
$(VENV)/.installed: pyproject.toml $(NATIVE) $(wildcard sarcli/*/__init__.py sarcli/*/*/__init__.py)
	@command -v $(CXX) >/dev/null 2>&1 || command -v g++ >/dev/null 2>&1 || { echo "sarcli's kernels need a C++17 compiler with OpenMP, and none was found (Debian/Ubuntu: apt-get install g++)"; exit 2; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet $$($(BIN)/python -c "import tomllib; print(' '.join(repr(r) for r in tomllib.load(open('pyproject.toml', 'rb'))['build-system']['requires']))" | tr -d "'")
	$(BIN)/python -m pip install --quiet --no-build-isolation --config-settings=build-dir=build/{wheel_tag} -e '.[test]'
	touch $@

setup: $(VENV)/.installed

# -- tests ---------------------------------------------------------------------------------------
# the fault-injection cases (real processes, signals, 1 s bounds) run alone, after the parallel run
test: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) -m "not faults"
	$(BIN)/python -m pytest -q -m faults

test-fast: $(VENV)/.installed
	$(BIN)/python -m pytest -q -x

stability: $(VENV)/.installed
	$(BIN)/python -m tests.stability.report

# -- demo: three points ------------------------------------------------------------------------
# spherical data (r0 = 10 km) for backprojection; the far-field model of the same scene for the
# far-field methods and the regulariser (nufft on the spherical file would warn of 1.1 rad defocus).
DEMO_CONFIG ?= configs/three-points.yaml
DEMO := $(OUT)/three-points

$(DEMO).h5: $(DEMO_CONFIG) $(VENV)/.installed
	@mkdir -p $(OUT)
	$(SAR) simulate $< -o $@ --seed 1

$(DEMO)-ff.h5: $(DEMO_CONFIG) $(VENV)/.installed
	@mkdir -p $(OUT)
	$(SAR) simulate $< -o $@ --seed 1 --model farfield

$(DEMO)-bp.h5: $(DEMO).h5
	$(SAR) form-image $< -o $@ --method backprojection --png $(DEMO)-bp.png --geotiff $(DEMO)-bp.tif

$(DEMO)-nufft.h5: $(DEMO)-ff.h5
	$(SAR) form-image $< -o $@ --method nufft --window taylor --png $(DEMO)-nufft.png --geotiff $(DEMO)-nufft.tif

$(DEMO)-quality.json: $(DEMO)-bp.h5 $(DEMO).h5
	$(SAR) quality $< --ph $(DEMO).h5 --json > $@.tmp && mv $@.tmp $@

$(DEMO)-ptv.h5: $(DEMO)-ff.h5
	$(SAR) regularize $< -o $@ --prior ptv --pixel-size 0.1 --lam 0.02 --tol 1e-3 --history-png $(DEMO)-ptv-history.png
	$(SAR) export $@ -o $(DEMO)-ptv.png
	$(SAR) export $@ -o $(DEMO)-ptv.tif

DEMO_FILES := $(DEMO).h5 $(DEMO)-ff.h5 $(DEMO)-bp.h5 $(DEMO)-nufft.h5 $(DEMO)-quality.json $(DEMO)-ptv.h5

demo: $(DEMO_FILES)
	$(BIN)/sar info $(DEMO).h5
	$(BIN)/sar quality $(DEMO)-bp.h5 --ph $(DEMO).h5
	@echo "demo outputs in $(OUT)/:"; ls -1 $(OUT) | sed 's/^/  /'

# -- real data: AFRL GOTCHA ---------------------------------------------------------------------
GOTCHA_FILES := $(wildcard $(GOTCHA)/data_3dsar_pass1_az00*_HH.mat)

$(OUT)/gotcha.h5: $(GOTCHA_FILES) $(VENV)/.installed
	@mkdir -p $(OUT)
	@test -n "$(GOTCHA_FILES)" || { echo "no GOTCHA files (data_3dsar_pass1_az00*_HH.mat) in $(GOTCHA): the data set is published by AFRL (see docs/conventions.md); point make at a copy with make gotcha GOTCHA=DIR or SARCLI_GOTCHA_DIR=DIR"; exit 2; }
	$(SAR) import gotcha $(GOTCHA_FILES) -o $@

$(OUT)/gotcha-bp.h5: $(OUT)/gotcha.h5
	$(SAR) form-image $< -o $@ --method backprojection --extent 100 --pixel-size 0.25 --png $(OUT)/gotcha-bp.png

$(OUT)/gotcha-ptv.h5: $(OUT)/gotcha.h5
	$(SAR) regularize $< -o $@ --prior ptv --operator spherical --extent 100 --pixel-size 0.25 --iters 30 --lam 0.02
	$(SAR) export $@ -o $(OUT)/gotcha-ptv.png

gotcha: $(OUT)/gotcha-bp.h5 $(OUT)/gotcha-ptv.h5
	@ls -1 $(OUT)/gotcha*

# -- the tutorial page, generated from the demo's outputs ----------------------------------------
tutorial: $(DEMO_FILES)
	$(BIN)/python scripts/tutorial.py $(OUT) docs

# -- the paper's figures -------------------------------------------------------------------------
paper: $(VENV)/.installed
	$(BIN)/python scripts/paper/run_all.py $(OUT)/paper docs/paper.md

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
	rm -rf $(VENV) build *.egg-info
