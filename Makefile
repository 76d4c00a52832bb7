# Quick start: `make run` (main job) and `make test` (test suite). Both create and reuse .venv.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
export MUJOCO_GL ?= egl

.PHONY: run test lint models clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev,bench,plot,corba]'
	touch $(STAMP)

run: $(STAMP)  ## the main job: imotiond on SmartPal V in MuJoCo + a scripted session -> out/demo/
	$(PY) tools/render_robots.py --out out/robots
	$(PY) tools/demo_session.py --out out/demo

test: $(STAMP)  ## the whole test suite (what CI runs)
	$(PY) -m pytest -q

lint: $(STAMP)  ## ruff, ruff format, mypy, import-linter (layers, no cycles)
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check . && $(VENV)/bin/mypy \
		&& $(VENV)/bin/lint-imports --no-logo

models: $(STAMP)  ## regenerate robot.urdf / robot.xml from model.yaml + profile.yaml
	$(PY) tools/gen_models.py

clean:
	rm -rf $(VENV) out
