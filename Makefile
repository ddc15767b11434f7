# Two commands on a fresh machine (see README):
#   make example   set up .venv; validate, configure and run the shipped SimpleBot with a hot swap
#   make test      set up .venv and run every check: ruff, mypy, pytest
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

$(BIN)/motivml: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $@

.PHONY: setup example test bench cpp-plugins
setup: $(BIN)/motivml

# The main job on the shipped robot: check a variant, generate its files, and run it for
# three seconds of simulated time with a hot swap of its SLAM plugin after one second.
example: setup
	$(BIN)/motivml validate feature_models/simplebot --variant field
	$(BIN)/motivml configure feature_models/simplebot --variant field
	$(BIN)/motivml run feature_models/simplebot --variant field --duration 3 --clock simulated \
	  --no-live --no-control --at 1 "swap hectorslam kartoslam"

# C++ plugins (needs cmake, g++, libclass-loader-dev): the motivml._cpp_plugins extension
# and the example plugin libraries in plugins/cpp.
cpp-plugins: setup
	cmake -S cpp_plugins -B build/cpp_plugins -DPython_EXECUTABLE=$(abspath $(BIN)/python) >/dev/null
	cmake --build build/cpp_plugins -j 2 >/dev/null

test: setup cpp-plugins
	$(BIN)/ruff check motivml tests bench plugins guidelines/examples tools
	$(BIN)/mypy
	$(BIN)/lint-imports
	COVERAGE_FILE=build/.coverage $(BIN)/pytest -q --cov=motivml --cov-report=json:build/coverage.json
	$(BIN)/python tools/coverage_floor.py build/coverage.json 90

bench: setup
	$(BIN)/python bench/startup_bench.py
	$(BIN)/python bench/validate_bench.py
	$(BIN)/python bench/configure_bench.py
	$(BIN)/python bench/run_bench.py
	$(BIN)/python bench/swap_bench.py
