# Two commands set up and run everything from a fresh clone:
#   make run   -- create .venv, install spherekin, solve the paper's Gosselin example (full joint ranges)
#   make test  -- create .venv, install spherekin with test extras, run the test suite
#   make verify -- symbolic verification of every claim of the paper; writes verification/REPORT.md
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test verify install clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

run: $(STAMP)
	$(BIN)/spherekin solve examples/gosselin.toml --inputs 0.3,-0.2,0.5

test: $(STAMP)
	$(BIN)/python -m pytest

verify: $(STAMP)
	$(BIN)/python -m verification

clean:
	rm -rf $(VENV) .pytest_cache *.egg-info
