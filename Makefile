# The two commands of the README. Each creates .venv when missing and installs maniplab into it.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint docs clean browser

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/maniplab demo -o out/demo

# ruff and mypy first: a lint or type error fails the test command as a failing test does
lint: $(STAMP)
	$(BIN)/ruff check src tests examples benchmarks
	$(BIN)/mypy

test: lint browser
	$(BIN)/python -m pytest -n 2

# the GUI's tests drive a real headless browser: Debian's chromium and its driver
browser:
	@test -x /usr/bin/chromedriver || { [ "$$(id -u)" = 0 ] && apt-get update -qq && \
	  apt-get install -y -qq chromium chromium-driver >/dev/null; } || \
	  { echo "make test needs chromium and chromium-driver: sudo apt-get install chromium chromium-driver" >&2; exit 1; }

# the documentation site in site/, offline and strict (tests/test_docs.py builds it too)
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict -d site

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis build src/*.egg-info
