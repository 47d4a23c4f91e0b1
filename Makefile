# Two entry points for a fresh machine with Python 3.11: `make run` and `make test-all`.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run check test test-all docs lint sessions bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,docs]'
	touch $(STAMP)

# The main job on the bundled sample sessions.
run: $(STAMP)
	$(BIN)/twopose-analyze run sessions/ --out results/

# The TypeScript MCAP reader the tests validate our files with (tests/node, Node.js >= 18).
NODE_STAMP := tests/node/node_modules/.installed
$(NODE_STAMP): tests/node/package.json tests/node/package-lock.json
	npm ci --prefix tests/node --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

# Lint, types and the docs, before any test.
check: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/mkdocs build --strict

# Tests run on both cores (pytest-xdist, each test to whichever process is free: 16.6 min
# for the whole suite here, against 24 on one core; a file's tests kept in one process
# took 20.8 on a busier machine) and print the 15 slowest.
PYTEST := $(BIN)/pytest -q -n 2 --dist load --durations=15

# The quick loop: everything but the tests marked slow (browsers, clusters, many-session fits).
test: check $(if $(shell command -v npm),$(NODE_STAMP))
	$(PYTEST) -m "not slow"

# The whole test suite, slow tests included (with the Node.js validation when node is here):
# what CI runs.
test-all: check $(if $(shell command -v npm),$(NODE_STAMP))
	$(PYTEST)

# The documentation site (docs/, mkdocs.yml) into site/, warnings as errors.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict

# Regenerate the bundled sample sessions (deterministic: same bytes every time).
sessions: $(STAMP)
	$(BIN)/python sessions/make_sessions.py sessions/

clean:
	rm -rf $(VENV) results/ site/ tests/node/node_modules .mypy_cache .pytest_cache .ruff_cache
