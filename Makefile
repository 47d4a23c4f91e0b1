# Two entry points for a fresh machine with Python 3.11: `make run` and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test lint sessions bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# The main job on the bundled sample sessions.
run: $(STAMP)
	$(BIN)/twopose-analyze run sessions/ --out results/

# The whole test suite: lint, types, tests.
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/pytest -q

# Regenerate the bundled sample sessions (deterministic: same bytes every time).
sessions: $(STAMP)
	$(BIN)/python sessions/make_sessions.py sessions/

clean:
	rm -rf $(VENV) results/ .mypy_cache .pytest_cache .ruff_cache
