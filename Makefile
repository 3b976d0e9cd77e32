# mcpt: every target installs what it needs (idempotent), so a fresh machine needs only Python.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SCENE ?= scenes/cornell-box.yaml

.PHONY: all setup system-deps render lint test test-osmesa bench bench-farm stability goldens wheel clean \
        peer peer-setup peer-system-deps

all: test

# Debian packages behind headless GL: EGL + llvmpipe, and OSMesa. Installed only when missing.
system-deps:
	@if ! ldconfig -p | grep -q 'libOSMesa.so' || ! ldconfig -p | grep -q 'libEGL_mesa.so' \
	    || ! ldconfig -p | grep -q 'libGL.so.1'; then \
	  echo "installing Mesa EGL/OSMesa (apt-get)"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	    libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libosmesa6 >/dev/null; \
	fi

$(STAMP): pyproject.toml setup.py | system-deps
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

setup: system-deps $(STAMP)

render: setup
	mkdir -p out
	$(VENV)/bin/mcpt render $(SCENE) --spp 256 -o out/cornell-box.png -o out/cornell-box.exr

# ruff (pyproject.toml [tool.ruff]) first: CI runs `make test`, so a lint finding fails CI too.
lint: setup
	$(VENV)/bin/ruff check .

test: setup lint
	$(PY) -m pytest -q

test-osmesa: setup
	MCPT_GL_BACKEND=osmesa $(PY) -m pytest -q

# The quick sweeps, then mcpt beside Mitsuba 3 (make peer; its side is skipped with one line if
# Mitsuba cannot be installed), then the README's pictures in bench/figures/ from both runs.
bench: setup
	$(PY) -m mcpt.bench.run --quick
	$(MAKE) --no-print-directory peer
	$(PY) -m mcpt.bench.figures --bench out/bench --out bench/figures --no-gallery
	$(PY) -m mcpt.bench.figures --bench $(PEER_OUT) --out bench/figures

# Issue #14: mcpt and Mitsuba 3 side by side (bench/peer.py). Mitsuba lives in its own venv,
# OUTSIDE the package (.venv-peer, ignored by git), and runs as a subprocess with that venv's python
# (MCPT_PEER_PYTHON). llvm_ad_rgb needs libLLVM >= 17 (drjit 1.5 emits llvm.minimum, which Debian's
# default libLLVM 15 cannot lower); ../shared/tools/peer_mitsuba.py finds the library by itself.
# If the Mitsuba side cannot be installed, `make peer` still runs mcpt's side and says so.
# Quick (default): 128x128, 8 bounces, 4/16/64/256 spp, 2 rounds, both scenes (~5 min on 2 cores);
# PEER_MODE=--full: 256x256 (the issue's size), 2 rounds (~4x longer).
PEER_MODE ?= --quick
PEER_VENV := .venv-peer
PEER_PY := $(PEER_VENV)/bin/python
PEER_STAMP := $(PEER_VENV)/.installed
PEER_OUT ?= out/bench-peer

peer-system-deps:
	@if ! ls /usr/lib/*-linux-gnu/libLLVM-1[7-9].so /usr/lib/*-linux-gnu/libLLVM-2[0-2].so \
	    /usr/lib/*-linux-gnu/libLLVM.so.1[7-9]* /usr/lib/*-linux-gnu/libLLVM.so.2[0-2]* 2>/dev/null | grep -q .; then \
	  echo "installing libllvm19 for Mitsuba's llvm_ad_rgb (apt-get)"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libllvm19 >/dev/null; \
	fi

$(PEER_STAMP): | peer-system-deps
	test -x $(PEER_PY) || $(PYTHON) -m venv $(PEER_VENV)
	$(PEER_PY) -m pip install -q mitsuba numpy openexr
	$(PEER_PY) -c "import mitsuba, drjit"
	touch $(PEER_STAMP)

peer-setup: peer-system-deps $(PEER_STAMP)

peer: setup
	@$(MAKE) --no-print-directory peer-setup \
	  || echo "peer-setup failed: the Mitsuba side will be skipped"
	MCPT_PEER_PYTHON=$${MCPT_PEER_PYTHON:-$(abspath $(PEER_PY))} $(PY) -m mcpt.bench.run $(PEER_MODE) --only peer -o $(PEER_OUT)

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
