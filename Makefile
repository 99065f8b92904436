# ballscrew_twin developer entry points. `make demo` and `make test` set the environment up first.
# All logic of the set-up lives in tools/setup_env.sh (idempotent: a second run takes seconds).

SHELL := /bin/bash
.DEFAULT_GOAL := help

VENV := .venv
BIN := $(VENV)/bin
DEMO_DURATION ?= 10

# DDS stays on this machine unless the caller says otherwise: loopback discovery only, and a
# domain of our own per make invocation (1..100, from the PID) so parallel runs do not meet.
# `?=` keeps values the user already exported (see docs/setup.md, "Using on a real bench network").
ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
ifeq ($(origin ROS_DOMAIN_ID),undefined)
ROS_DOMAIN_ID := $(shell echo $$(( $$$$ % 100 + 1 )))
endif
ROS_ENV := ROS_AUTOMATIC_DISCOVERY_RANGE=$(ROS_AUTOMATIC_DISCOVERY_RANGE) ROS_DOMAIN_ID=$(ROS_DOMAIN_ID)

# Guard of the ROS wheels' start-up re-exec: never inherit it from another environment.
unexport _ROS_WHEELS_BOOTSTRAP_COMPLETE

.PHONY: help setup test lint typecheck pytest demo node clean distclean

help:
	@echo "make demo       set up if needed, run the twin node, a command script and a console view ($(DEMO_DURATION) s)"
	@echo "make test       set up if needed, then ruff check and format check, the import contract, mypy, pytest"
	@echo "make setup      create/update .venv (ROS 2 Jazzy wheels, messages, editable install)"
	@echo "make node       run the twin node with config/twin_node.yaml until Ctrl-C"
	@echo "make clean      remove caches and the message build dir; distclean also removes .venv"

setup:
	@bash tools/setup_env.sh

# pytest runs in TEST_WORKERS processes (pytest-xdist; a test module stays on one worker, and
# each worker has a ROS domain of its own, test/conftest.py); mypy (one core, ~30 s from a cold
# cache) runs beside it. Its report is printed after pytest's, and either failing fails the target.
# --no-loadscope-reorder: the modules go to the workers in collection order, which
# test/conftest.py puts slowest first (xdist's default order is by number of tests).
TEST_WORKERS ?= 2
PYTEST := $(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadscope --no-loadscope-reorder
# The import contract of pyproject.toml ([tool.importlinter]: layers, forbidden imports, no
# circles; docs/architecture.md). It reads the package in this directory; under a second its
# graph is rebuilt each run, so no cache directory is kept.
LINT_IMPORTS := $(BIN)/lint-imports --no-cache --no-logo pyproject.toml

test: setup
	$(BIN)/ruff check ballscrew_twin test
	$(BIN)/ruff format --check ballscrew_twin test
	$(LINT_IMPORTS)
	@echo "$(BIN)/mypy ballscrew_twin (beside pytest) & $(ROS_ENV) $(PYTEST)"
	@report=$$(mktemp); \
	$(BIN)/mypy ballscrew_twin > "$$report" 2>&1 & checker=$$!; \
	$(ROS_ENV) $(PYTEST); tests=$$?; \
	wait $$checker; types=$$?; \
	echo "$(BIN)/mypy ballscrew_twin:"; cat "$$report"; rm -f "$$report"; \
	exit $$(( tests || types ))

lint: setup
	$(BIN)/ruff check ballscrew_twin test
	$(BIN)/ruff format --check ballscrew_twin test
	$(LINT_IMPORTS)

typecheck: setup
	$(BIN)/mypy ballscrew_twin

pytest: setup
	$(ROS_ENV) $(PYTEST)

demo: setup
	@$(ROS_ENV) DEMO_DURATION=$(DEMO_DURATION) bash tools/run_demo.sh

node: setup
	$(ROS_ENV) $(BIN)/twin_node --ros-args --params-file config/twin_node.yaml

clean:
	rm -rf build .pytest_cache .mypy_cache .ruff_cache
	find ballscrew_twin test -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV) *.egg-info
