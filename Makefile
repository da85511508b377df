# GidaBot — the two commands a newcomer types are `make demo` and `make test`.
SHELL := /bin/bash
.DEFAULT_GOAL := help
ROOT := $(CURDIR)

.PHONY: help setup apt venv build test unit system lint demo clean

help:
	@echo "make setup   install Debian ROS packages, the venv (pinned PyPI extras) and build (idempotent)"
	@echo "make test    setup + build when needed, then lint, unit tests (no master) and system tests"
	@echo "make demo    setup + build when needed, then run the simulated building (bin/gidabot demo)"
	@echo "             options: make demo DEMO_ARGS='--tour tours/long_tour.tour --speed 10 --gui' (docs/demo.md)"
	@echo "make lint    ruff + catkin_lint"
	@echo "make clean   remove build/, devel/ (keeps the venv)"

setup:
	tools/setup.sh all

apt:
	tools/setup.sh apt

venv:
	tools/setup.sh venv

build:
	tools/setup.sh build

test: setup
	tools/run-tests.sh all

unit: setup
	tools/run-tests.sh unit

system: setup
	tools/run-tests.sh system

lint: setup
	tools/run-tests.sh lint

demo: setup
	bin/gidabot demo $(DEMO_ARGS)

clean:
	rm -rf build devel install .stamps/catkin_make.log
