"""The tests' own probe shaders (tests/glsl/): each runs one of the renderer's GLSL routines (or
reads back a buffer) per item, through bench/probe.py's :func:`~mcpt.bench.probe.run_probe`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mcpt.bench.probe import run_probe

GLSL = Path(__file__).resolve().parent / "glsl"


def run_test_probe(gl, name: str, probe: np.ndarray, count: int, **kwargs) -> np.ndarray:
    """:func:`run_probe` of the probe ``tests/glsl/<name>``."""
    return run_probe(gl, GLSL / name, probe, count, **kwargs)
