# The two commands of the README. Each creates .venv when missing and installs maniplab into it.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
FMPY := .venv-fmpy/bin/fmpy
# apt-get waits up to 10 minutes for a dpkg lock another installer holds, instead of failing
APT := apt-get -o DPkg::Lock::Timeout=600

.PHONY: demo test lint docs clean browser octave

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

test: lint browser octave $(FMPY)
	$(BIN)/python -m pytest -n 2

# the GUI's tests drive a real headless browser: Debian's chromium and its driver
browser:
	@test -x /usr/bin/chromedriver || { [ "$$(id -u)" = 0 ] && $(APT) update -qq && \
	  $(APT) install -y -qq chromium chromium-driver >/dev/null; } || \
	  { echo "make test needs chromium and chromium-driver: sudo apt-get install chromium chromium-driver" >&2; exit 1; }

# the MATLAB export's tests run the generated functions in GNU Octave (Debian's octave)
octave:
	@command -v octave-cli >/dev/null || { [ "$$(id -u)" = 0 ] && $(APT) update -qq && \
	  $(APT) install -y -qq --no-install-recommends octave >/dev/null; } || \
	  { echo "make test needs GNU Octave: sudo apt-get install octave" >&2; exit 1; }

# the FMU's tests load it in a virtual environment that has FMPy and nothing of maniplab
$(FMPY):
	$(PYTHON) -m venv .venv-fmpy
	.venv-fmpy/bin/python -m pip install --quiet 'fmpy>=0.3.20'

# the documentation site in site/, offline and strict (tests/test_docs.py builds it too)
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict -d site

clean:
	rm -rf $(VENV) .venv-fmpy out .pytest_cache .hypothesis build src/*.egg-info

# maniplab's C code under AddressSanitizer and UBSan: the native library and an FMU's C functions
# built with MANIPLAB_NATIVE_SANITIZE=1 (a cache folder of their own), the native tests and the
# fuzzing of tests/sanitize/ (docs/guide/safety.md, "Sanitizers")
.PHONY: sanitize
sanitize: $(STAMP)
	$(BIN)/python tests/sanitize/run.py

# mutation testing (not part of make test): one small change at a time to the physics, control,
# identification, FMU and load-chart sources, in a private copy of HEAD, against focused tests;
# a fixed sample per group (MUTANTS_ARGS="--sample 0" for all); results in out/mutants/
# (docs/about/development.md, "Mutation testing")
.PHONY: mutants
MUTANTS_ARGS ?=
mutants: $(STAMP)
	nice -n 10 $(BIN)/python tests/mutants/run.py $(MUTANTS_ARGS)
