# Two commands set up and run everything from a fresh clone:
#   make run   -- create .venv, install spherekin, solve the paper's Gosselin example (full joint ranges)
#   make test  -- create .venv, install spherekin with test extras, run the test suite's first tier (under 5 min on
#     2 cores: every module, one example per command; TEST_WORKERS processes, default 2)
#   make test-long -- the long tier (tests/tiers.toml and the slow sweeps: Dask faults, the gallery, the wheel,
#     the campaigns, the slowest tests) and the site in headless Chromium (docs-check; installs Debian's chromium
#     and chromium-driver when missing)
#   make test-all -- make test, then make test-long (.ci/run runs it)
#   make verify -- symbolic verification of every claim of the paper; writes verification/REPORT.md
#   make experiments [FULL=1] -- the experiments of experiments/README.md (quick by default)
#   make figures -- the paper figures (paper_figures/*.png, *.pdf)
#   make bench / bench-peers / sweep / edge -- benchmarks/README.md (speed, PHCpack comparison, never-lose-a-root
#     sweep, the no-false-proof campaign next to branch, change and singular inputs: ~20 min)
#   make doc-numbers -- the times and counts the pages quote, measured (benchmarks/doc_numbers.json; ~15 min)
#   make singular-campaign -- every singular cover against solve_many's counts and branch_map (~30 min CPU x 2 cores)
#   make docs -- the documentation site into docs/_build/html (installs the [docs] extra; warnings are errors)
#   make docs-check -- the site built afresh and checked in headless Chromium (installs Debian's chromium and
#     chromium-driver when missing)
#   make mutants [ONLY=ID] -- hand-written bugs in the trust layer; fails if the tests miss one (mutation/README.md)
# Scripts of benchmarks/, experiments/, paper_figures/ are modules: run them as python -m benchmarks.bench_solve.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DOCS_STAMP := $(VENV)/.installed-docs

EXPERIMENTS := reproduction convergence parameterizations lp_backends scaling tan_vs_sincos
QUICK_FLAG := $(if $(FULL),,--quick)

.PHONY: run test test-long test-all chromium doc-numbers verify install clean experiments figures bench bench-peers sweep edge singular-campaign mutants docs docs-check

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

# the [docs] extra on top of the test install (make test never needs it)
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $(DOCS_STAMP)

run: $(STAMP)
	$(BIN)/spherekin solve examples/gosselin.toml --inputs 0.3,-0.2,0.5

# processes of the test run (pytest-xdist); the Dask tests start clusters of their own in each
TEST_WORKERS ?= 2

test: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_WORKERS)

# the long tier: what make test leaves out (pytest -m slow: tests/tiers.toml), then the site in a real browser
test-long: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_WORKERS) -m slow -q --ignore=tests/test_docs_site.py
	$(MAKE) --no-print-directory docs-check

test-all: test test-long

verify: $(STAMP)
	$(BIN)/python -m verification

experiments: $(STAMP)
	@for e in $(EXPERIMENTS); do \
		test -f experiments/$$e.py || { echo "experiments/$$e.py: missing"; exit 1; }; \
		echo "== experiments/$$e.py $(QUICK_FLAG)"; \
		MPLBACKEND=Agg $(BIN)/python -m experiments.$$e $(QUICK_FLAG) || exit 1; \
	done

figures: $(STAMP)
	@for f in paper_figures/fig*.py paper_figures/exp_*.py; do \
		echo "== $$f"; \
		MPLBACKEND=Agg $(BIN)/python -m paper_figures.$$(basename $$f .py) || exit 1; \
	done

bench: $(STAMP)
	$(BIN)/python -m benchmarks.bench_solve
	$(BIN)/python -m benchmarks.bench_certify
	$(BIN)/python -m benchmarks.bench_many
	$(BIN)/python -m benchmarks.bench_process
	$(BIN)/python -m benchmarks.bench_batch
	$(BIN)/python -m benchmarks.bench_track
	$(BIN)/python -m benchmarks.bench_engine

bench-peers: $(STAMP)
	@command -v phc >/dev/null || { echo "phc not found: installing PHCpack (Debian package phcpack)"; \
		apt-get install -y -qq phcpack >/dev/null || sudo apt-get install -y -qq phcpack >/dev/null || \
		echo "could not install phcpack: the PHCpack rows are skipped"; }
	$(BIN)/python -m benchmarks.bench_peers

sweep: $(STAMP)
	$(BIN)/python -m benchmarks.sweep_roots --poses 1000 --jobs 2

edge: $(STAMP)
	$(BIN)/python -m benchmarks.edge_campaign --jobs 2

doc-numbers: $(STAMP)
	$(BIN)/python -m benchmarks.doc_numbers

singular-campaign: $(STAMP)
	$(BIN)/python -m benchmarks.singular_campaign --jobs 2

mutants: $(STAMP)
	$(BIN)/python mutation/run.py $(if $(ONLY),--only $(ONLY))

docs: $(DOCS_STAMP)
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

# Debian's Chromium and ChromeDriver, installed when missing (as root, or through sudo)
chromium:
	@command -v chromium >/dev/null && command -v chromedriver >/dev/null || { \
	  echo "installing Chromium and ChromeDriver (Debian packages chromium, chromium-driver)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get install -y -qq chromium chromium-driver >/dev/null 2>&1 || \
	  { $$SUDO apt-get update -qq >/dev/null && $$SUDO apt-get install -y -qq chromium chromium-driver >/dev/null; } || \
	  { echo "could not install chromium and chromium-driver (apt-get): the site cannot be checked"; exit 2; }; }

# tests/test_docs_site.py skips itself where Chromium is missing: here that is an error, not a skip
docs-check: $(DOCS_STAMP) chromium
	$(BIN)/python -m pytest tests/test_docs_site.py -q -rs -m "slow or not slow"

clean:
	rm -rf $(VENV) .pytest_cache *.egg-info docs/_build docs/generated docs/gallery docs/sg_execution_times.rst
