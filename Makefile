# exodigit: the two commands a user needs.
#   make run [DURATION=20] [RECORD=1] [HAND=1] [ACTUATION=valves]
#                            the simulated glove, headless, with a live summary (Ctrl-C to stop);
#                            RECORD=1 also records every topic to a rosbag2 (MCAP) bag
#                            (with HAND=1 one per finger);
#                            HAND=1 runs a whole hand instead (five gloves, one process);
#                            ACTUATION=valves drives the chambers by inlet and outlet valves
#                            (plant actuation valves, pressure_command output valves)
#   make run HARDWARE=emulated|/dev/ttyACM0
#                            the glove through the hardware bridge on an emulated board, or on
#                            the board at that port (docs/hardware.md)
#   make test [PYTEST_WORKERS=2] [PYTEST_ARGS=...]
#                            lint, format check, the documentation site and the whole test
#                            suite (what CI runs)
#   make docs                the documentation site into build/docs/ (Sphinx, warnings as errors;
#                            docs/development.md, "The documentation site")
# Both create .venv and install everything on first use; later calls only re-install when a
# requirements or package file changed. Both also compile the model's kernels into numba's cache
# (`make warm`, docs/compiled.md) when their sources changed, so no test or node compiles.

SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
DURATION ?= 0
NAMESPACE ?= /glove
RECORD ?=
ACTUATION ?=
HARDWARE ?=
PYTEST_ARGS ?=
# Test workers (pytest-xdist; docs/development.md, "The two commands"): two, for this project's two-core VMs;
# 0 runs every test in the one pytest process.
PYTEST_WORKERS ?= 2

# Discovery never leaves this machine (docs/networking.md, "Networking"); one domain per command.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_DOMAIN_ID ?= 37
export PIP_DISABLE_PIP_VERSION_CHECK := 1
export MPLBACKEND := Agg

INSTALL_INPUTS := requirements/ros.txt requirements/dev.txt requirements/docs.txt \
	$(wildcard exodigit_model/pyproject.toml exodigit_model/setup.py \
	           exodigit_nodes/setup.py exodigit_nodes/setup.cfg)

# The kernels' cache is named after their sources (exodigit_model/kernels/jit.py); the modules
# that call them decide their argument types, hence which signatures the warm-up compiles.
WARM_INPUTS := $(wildcard exodigit_model/exodigit_model/kernels/*.py \
	                    exodigit_model/exodigit_model/physics/*.py \
	                    exodigit_model/exodigit_model/stepping/*.py \
	                    exodigit_model/exodigit_model/tools/warm.py)

# The site is built again when a page, a picture or a docstring changed (like the kernels' cache
# above); every build starts afresh (-E), so each warning of every page shows, and fails (-W).
DOCS_OUT := build/docs
DOCS_INPUTS := README.md $(shell find docs -path docs/api -prune -o -type f -print) \
	$(shell find exodigit_model/exodigit_model exodigit_nodes/exodigit_nodes -name '*.py')

.PHONY: run test docs venv warm bench clean

venv: $(VENV)/.installed

warm: $(VENV)/.warm

$(VENV)/.installed: $(INSTALL_INPUTS)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip setuptools wheel
	$(BIN)/python -m pip install --quiet -r requirements/ros.txt -r requirements/dev.txt \
		-r requirements/docs.txt
	$(BIN)/python -m pip install --quiet --config-settings editable_mode=compat -e './exodigit_model[tools,gym,ray]'
	if [ -f exodigit_nodes/setup.py ]; then $(BIN)/python -m pip install --quiet --config-settings editable_mode=compat -e ./exodigit_nodes; fi
	touch $@

# Compiles every kernel into the cache (or only loads it when nothing changed) and removes the
# caches of older kernel sources.
$(VENV)/.warm: $(VENV)/.installed $(WARM_INPUTS)
	$(BIN)/python -m exodigit_model.tools.warm
	touch $@

run: warm
ifdef HAND
	$(BIN)/python -m exodigit_nodes.hand --duration $(DURATION) $(if $(RECORD),--record) \
		$(if $(ACTUATION),--actuation $(ACTUATION))
else
	$(BIN)/python -m exodigit_nodes.glove --duration $(DURATION) --namespace $(NAMESPACE) \
		$(if $(RECORD),--record) $(if $(ACTUATION),--actuation $(ACTUATION)) \
		$(if $(HARDWARE),--hardware $(HARDWARE))
endif

docs: $(DOCS_OUT)/.built

# sphinx-autoapi writes the API pages into docs/api/ while it builds and removes them after.
$(DOCS_OUT)/.built: $(VENV)/.installed $(DOCS_INPUTS)
	rm -rf docs/api
	$(BIN)/python -m sphinx -b html -E -W --keep-going -q docs $(DOCS_OUT)
	touch $@

test: warm docs
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest --numprocesses $(PYTEST_WORKERS) --dist loadfile $(PYTEST_ARGS)

bench: warm
	$(BIN)/python benchmarks/bench_model.py

clean:
	rm -rf $(VENV) runs build docs/api ros_ws/build ros_ws/install ros_ws/log
