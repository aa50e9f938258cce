# Two set-up commands: `make demo` and `make test`. Each creates .venv on first use.
# The package is installed non-editable, so tests exercise what users install
# (levels shipped as package data included); the stamp re-installs on any source change.
# Prefer the system interpreter: when the referee runs as root, controllers run as `nobody`,
# who must be able to start the venv's Python (a pyenv under /root would be closed to it).
PYTHON ?= $(shell test -x /usr/bin/python3 && echo /usr/bin/python3 || echo python3)
VENV   := .venv
PY     := $(VENV)/bin/python
SOURCES := pyproject.toml $(shell find arena robots referee levels -name '*.py' -o -name '*.yaml' -o -name '*.html' -o -name '*.js' 2>/dev/null)
export SDL_VIDEODRIVER ?= dummy
export SDL_AUDIODRIVER ?= dummy

.PHONY: demo lint test bench fidelity baselines clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)

$(VENV)/.installed: $(VENV)/bin/python $(SOURCES)
	$(PY) -m pip install --quiet --upgrade pip
	rm -rf build  # setuptools' staging folder would keep modules that have moved or gone
	$(PY) -m pip install --quiet '.[test,dask,rl]'
	$(PY) -P -m referee.match.warm  # numba's kernels compiled now, not in the first match (-P: the installed copy's)
	touch $@

demo: $(VENV)/.installed
	mkdir -p out
	$(VENV)/bin/laserarena run asabe --json out/demo.json --replay out/demo.replay
	$(VENV)/bin/laserarena render out/demo.replay --out out/demo.mp4 --fps 15
	$(VENV)/bin/laserarena verify out/demo.replay

# Lint, format and types (settings in pyproject.toml).
LINT_PATHS := arena robots referee levels tests benchmarks
lint: $(VENV)/.installed
	$(VENV)/bin/ruff check $(LINT_PATHS)
	$(VENV)/bin/ruff format --check $(LINT_PATHS)
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

# the suite on every CPU (at most 4 workers), then, alone, the tests that load the machine or time a neighbour
test: lint
	cd tests && ../$(VENV)/bin/python -m pytest -q -p no:cacheprovider -n auto --maxprocesses 4 -m "not alone"
	cd tests && ../$(VENV)/bin/python -m pytest -q -p no:cacheprovider -m alone

bench: $(VENV)/.installed
	$(VENV)/bin/python benchmarks/all.py  # writes docs/performance.json and sets the figures the docs quote from it

baselines: $(VENV)/.installed
	$(VENV)/bin/python benchmarks/baselines.py --out docs/baselines.md

fidelity: $(VENV)/.installed
	$(VENV)/bin/python benchmarks/fidelity.py --out docs/fidelity.md

clean:
	rm -rf $(VENV) out build *.egg-info
