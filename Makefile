# Two commands on a fresh machine (see README):
#   make example   set up .venv; validate, configure and run the shipped SimpleBot with a hot swap
#   make test      set up .venv and run every check: ruff, mypy, pytest (the ROS 2 tests in .venv-ros)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# ROS 2's wheels re-execute every Python of their environment at start-up (a .pth hook), so
# they live in a venv of their own: `make ros2`, then .venv-ros/bin/motivml run ... --ros2.
ROS_VENV := .venv-ros
ROS_BIN := $(ROS_VENV)/bin

$(BIN)/motivml: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $@

$(ROS_BIN)/motivml: pyproject.toml
	$(PYTHON) -m venv $(ROS_VENV)
	$(ROS_BIN)/pip install --quiet --upgrade pip
	$(ROS_BIN)/pip install --quiet -e '.[dev,ros2]'
	touch $@

.PHONY: setup ros2 example test bench cpp-plugins
setup: $(BIN)/motivml
ros2: $(ROS_BIN)/motivml

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

# The ROS 2 tests (marked ros2) skip in .venv, which has no rclpy, and run in .venv-ros on a
# ROS graph of their own on loopback; MOTIVML_REQUIRE_ROS2 makes a skip there a failure.
test: setup cpp-plugins ros2
	$(BIN)/ruff check motivml tests bench plugins guidelines/examples tools
	$(BIN)/mypy
	$(BIN)/lint-imports
	rm -f build/.coverage*
	# PYTHONFAULTHANDLER: a crash, even while the interpreter shuts down after the tests,
	# prints where every thread was (pytest's own handler is gone by then).
	# --slow: every test, the slow ones too (pytest alone leaves them out). The tests run in
	# one worker per core (pyproject.toml's addopts), each ROS 2 test on a ROS_DOMAIN_ID that
	# no other worker holds (tests/ros2_support.py).
	PYTHONFAULTHANDLER=1 COVERAGE_FILE=build/.coverage $(BIN)/pytest -q --slow --cov=motivml --cov-report=
	PYTHONFAULTHANDLER=1 COVERAGE_FILE=$(CURDIR)/build/.coverage COVERAGE_PROCESS_START=$(CURDIR)/pyproject.toml \
	  MOTIVML_REQUIRE_ROS2=1 $(ROS_BIN)/pytest -q -m ros2 \
	  --cov=motivml --cov-append --cov-report=json:build/coverage.json
	$(BIN)/python tools/coverage_floor.py build/coverage.json 90

bench: setup cpp-plugins ros2
	$(BIN)/python bench/startup_bench.py
	$(BIN)/python bench/validate_bench.py
	$(BIN)/python bench/xor_bench.py
	$(BIN)/python bench/analyse_bench.py
	$(BIN)/python bench/families_bench.py --flamapy
	$(BIN)/python bench/compiled_bench.py
	$(BIN)/python bench/menuconfig_bench.py --counts
	$(BIN)/python bench/sample_bench.py
	$(BIN)/python bench/configure_bench.py
	$(BIN)/python bench/run_bench.py
	$(BIN)/python bench/swap_bench.py
	$(ROS_BIN)/python bench/ros2_bench.py
	$(ROS_BIN)/python bench/ros2_bench.py --priority 0
	$(ROS_BIN)/python bench/ros2_bench.py --pinned
	$(ROS_BIN)/python bench/fleet_bench.py
