# Two entry points for a newcomer (see README.md):
#   make demo   set up .venv and run the main job
#   make test   set up .venv and run the linter and the test suite
#   make test-quick   the test suite without the end-to-end tier (pytest -m "not slow ...")
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test test-quick bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "Python >= 3.11 is required"'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/ilpss-demo --out results/demo

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -n 2 -q

test-quick: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q -m "not slow and not integrations"

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_env.py

clean:
	rm -rf $(VENV) results .pytest_cache
