# mcpt: every target installs what it needs (idempotent), so a fresh machine needs only Python.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SCENE ?= scenes/cornell-box.yaml

.PHONY: all setup system-deps render test test-osmesa bench bench-farm stability goldens wheel clean

all: test

# Debian packages behind headless GL: EGL + llvmpipe, and OSMesa. Installed only when missing.
system-deps:
	@if ! ldconfig -p | grep -q 'libOSMesa.so' || ! ldconfig -p | grep -q 'libEGL_mesa.so' \
	    || ! ldconfig -p | grep -q 'libGL.so.1'; then \
	  echo "installing Mesa EGL/OSMesa (apt-get)"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	    libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libosmesa6 >/dev/null; \
	fi

$(STAMP): pyproject.toml | system-deps
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	# PYTHONWARNINGS: setuptools' notes on editable installs of mapped packages are not for users.
	PYTHONWARNINGS=ignore $(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

setup: system-deps $(STAMP)

render: setup
	mkdir -p out
	$(VENV)/bin/mcpt render $(SCENE) --spp 256 -o out/cornell-box.png -o out/cornell-box.exr

test: setup
	$(PY) -m pytest -q

test-osmesa: setup
	MCPT_GL_BACKEND=osmesa $(PY) -m pytest -q

bench: setup
	$(PY) -m mcpt.bench.run --quick
	$(PY) -m mcpt.bench.figures --bench out/bench --out bench/figures

# Issue #11: Cornell box in one process against a 2-worker Dask LocalCluster (bench/RESULTS.md).
bench-farm: setup
	$(PY) -m mcpt.bench.farm --resolution 64 --spp 1024 --rounds 3

# Issue #6: the stability suite as a table (case, expected, measured, pass/fail); the same cases
# run in CI as tests/test_stability.py. GL_BACKEND=osmesa to run it on OSMesa.
stability: setup
	$(PY) -m mcpt.bench.stability $(if $(GL_BACKEND),--gl-backend $(GL_BACKEND))

# Regenerate the golden images of tests/test_golden.py (reference mean + per-sample variance,
# ~2 min on llvmpipe); commit tests/golden/*.npz afterwards.
goldens: setup
	$(PY) -m tests.goldens

wheel: setup
	$(PY) -m pip wheel --no-deps -w dist .

clean:
	rm -rf out dist build *.egg-info
