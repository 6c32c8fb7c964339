# Two commands on a fresh machine: `make demo` and `make test`.
# Each creates (or refreshes, when pyproject.toml changed) a local virtual
# environment in .venv, installs encal into it from this checkout and its
# dependencies from PyPI.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

# encal's matrices are small: one BLAS thread per process is fastest on 2 cores.
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: demo test bench clean venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/encal demo --out encal-demo

# One pytest-xdist worker per CPU, each running whole test files (a file's module fixtures, some of them
# a demo or a two-process run, are then made once).
test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadfile

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[test,bench]"
	for script in benchmarks/bench_*.py; do $(BIN)/python $$script || exit 1; done

clean:
	rm -rf $(VENV) encal-demo .pytest_cache .hypothesis
