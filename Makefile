# FORTE workspace. Every target sets itself up first; see README.md.
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
ROOT := $(abspath $(dir $(lastword $(MAKEFILE_LIST))))
ENV := source $(ROOT)/install/setup.bash
PYTEST_ARGS ?=
# LAUNCH_KIT=DIR: also install the launch stack and ros2 CLI from a launch kit (README)
LAUNCH_KIT ?=

.PHONY: setup test test-python test-firmware lint demo bench faults evaluate clean

## setup: venv (pinned ROS 2 Jazzy wheels unless ROS is sourced), colcon build into install/ (idempotent)
setup:
	@bash $(ROOT)/tools/setup.sh $(if $(LAUNCH_KIT),--launch-kit $(LAUNCH_KIT))

## test: every test (pytest across packages, firmware C tests, linters)
test: setup
	@$(MAKE) --no-print-directory test-firmware
	@$(MAKE) --no-print-directory lint
	@$(MAKE) --no-print-directory test-python

test-python:
	@$(ENV) && cd $(ROOT) && python tools/run_tests.py $(PYTEST_ARGS)

test-firmware:
	@if [ -f $(ROOT)/firmware/Makefile ]; then $(MAKE) --no-print-directory -C $(ROOT)/firmware test; \
	 else echo "[test] firmware: no firmware/Makefile yet"; fi

## lint: ruff over every Python package
lint:
	@$(ENV) && cd $(ROOT) && ruff check $$(ls -d forte_ros forte_msgs forte_description forte_driver forte_sim forte_perception forte_control forte_evaluation forte_bringup forte_commissioning hardware benchmarks tools conftest.py 2>/dev/null) && echo "[lint] ruff: clean"

## demo: the simulated FORTE scene with the full graph (see README)
demo: setup
	@$(ENV) && cd $(ROOT) && python -m forte_bringup.demo

## bench: speed and memory benchmarks, each against a baseline measured in the same run
bench: setup
	@$(ENV) && cd $(ROOT) && for b in benchmarks/bench_*.py; do echo "=== $$b"; python $$b; done

## faults: serial fault-injection streams, 1e7 scans (FAULTS_ARGS=--quick for 1e6), docs/serial_driver.md
faults: setup
	@$(ENV) && cd $(ROOT) && python benchmarks/bench_fault_streams.py $(FAULTS_ARGS)

## evaluate: the paper's evaluation reproduced in simulation (EVAL_ARGS=--quick for a subset)
evaluate: setup
	@$(ENV) && cd $(ROOT) && python -m forte_evaluation.evaluate $(EVAL_ARGS)

## results: evaluate, slip benchmark (sequential, paper), then docs/results.md from their JSON (EVAL_ARGS as for evaluate)
results: setup
	@$(ENV) && cd $(ROOT) && python -m forte_evaluation.evaluate $(EVAL_ARGS) && python -m forte_evaluation.slip_benchmark --mode sequential && python -m forte_evaluation.slip_benchmark --mode paper && python tools/results_page.py

clean:
	rm -rf $(ROOT)/build $(ROOT)/install $(ROOT)/.venv $(ROOT)/log
