# The two commands a new user needs. Each makes (or refreshes) a local virtual
# environment in .venv, installs cranktrack into it, and runs.
#   make demo   render the default spool scene, track it, compare with the model
#   make test   lint, then the fast test suite

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# setuptools warns on every editable install that a folder named like the package may
# shadow it. Here the checkout *is* the package, so such a folder holds the same code;
# the block would only hide the demo's output, so that one warning is silenced.
PIP    := PYTHONWARNINGS="ignore:Editable installation" $(BIN)/python -m pip \
          --disable-pip-version-check --quiet

.PHONY: demo test test-slow lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip

# numba compiles each kernel on first use and caches it on disk: do it once here,
# so the first command a user runs is not 6-8 s slower than every later one.
WARMUP := @echo "compiling cranktrack's numba kernels once (cached on disk)..." && \
          $(BIN)/python -c "from cranktrack.warmup import compile_kernels; compile_kernels()"

# Stamps: reinstall only when pyproject.toml changes.
$(VENV)/.installed-run: pyproject.toml | $(BIN)/python
	$(PIP) install -e .
	$(WARMUP)
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(PIP) install -e '.[test]'
	$(WARMUP)
	touch $@ $(VENV)/.installed-run

demo: $(VENV)/.installed-run
	$(BIN)/cranktrack demo

test: $(VENV)/.installed-test
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -n auto --dist worksteal

# The tests marked slow (closed-loop fits of the SMA model on renders), not in `make test`.
test-slow: $(VENV)/.installed-test
	$(BIN)/python -m pytest -m slow

lint: $(VENV)/.installed-test
	$(BIN)/ruff check .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
