# msspr: the two commands are `make demo` and `make test` (see README.md).
SHELL := /bin/bash
BUILD ?= build
JOBS ?= 2
# Debian's catkin needs Debian's python (not a pyenv shim) first on PATH.
export PATH := /usr/bin:/bin:$(PATH)
# The devel space (executables, setup.bash) lives at the package root: rosrun
# ignores everything under <package>/build/.
DEVEL ?= $(CURDIR)/devel
# WERROR=ON: warnings in msspr's own code are errors (CI builds so).
WERROR ?= OFF
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
               -DPython3_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON \
               -DCATKIN_DEVEL_PREFIX=$(DEVEL) -DMSSPR_WERROR=$(WERROR)

.PHONY: all deps configure build build-demo test demo bench core clean format

all: build

deps:
	@scripts/install_deps.sh

configure:
	@test -f $(BUILD)/CMakeCache.txt || cmake -S . -B $(BUILD) $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD) -j$(JOBS)
	cmake --build $(BUILD) --target tests -j$(JOBS)

test: deps
	@$(MAKE) --no-print-directory build
	@scripts/run_tests.sh $(BUILD)

# What `make demo` runs (launch/demo.launch, expert_demo.launch): the sim, the
# expert, the policy node and the evaluator, one CMake target (msspr_demo_targets);
# the other tools and the tests come with `make build`.
build-demo: configure
	cmake --build $(BUILD) -j$(JOBS) --target msspr_demo_targets

demo: deps
	@$(MAKE) --no-print-directory build-demo
	@scripts/demo.sh $(BUILD)

bench: deps
	@$(MAKE) --no-print-directory build
	@scripts/bench.sh $(BUILD)

# The ROS-free core alone (as on a GPU machine): make core CORE_FLAGS=-DCMAKE_PREFIX_PATH=...
core:
	cmake -S msspr_core -B build-core -DCMAKE_BUILD_TYPE=Release $(CORE_FLAGS)
	cmake --build build-core -j$(JOBS)

format:
	find msspr_core msspr_sim msspr_policy_node tests -name '*.h' -o -name '*.cc' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(DEVEL) build-core
