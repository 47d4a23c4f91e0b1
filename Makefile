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

# Tests run on both cores in three pytest-xdist processes: a third keeps both cores busy
# while a test waits (a browser drawing, a server's timeout, a subprocess starting), which
# two left idle (about a third of a test's time in tests/analysis, measured as wall time
# beyond its CPU time). Each process takes a third of the tests in order (each module's
# tests together: its module-scoped fixtures made once) and a process that runs out takes
# half of another's remaining tests (--dist worksteal), so that no core is left idle at
# the end while one process finishes a long module alone. Prints the 15 slowest.
PYTEST := $(BIN)/pytest -q -n 3 --dist worksteal --durations=15

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
