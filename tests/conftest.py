import os
from functools import lru_cache
from pathlib import Path

import numpy as np

import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"


@pytest.fixture(scope="session")
def gl():
    """The GL context of the back end under test (MCPT_GL_BACKEND: egl, osmesa; default auto)."""
    from mcpt.gpu.context import shared_context

    return shared_context(os.environ.get("MCPT_GL_BACKEND"))


def shared_path(*parts) -> Path:
    p = SHARED.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"shared material missing: {p}")
    return p


@lru_cache(maxsize=1)
def bunny_reference():
    """Bunny triangles, its BVH, 10^4 rays (float32-representable) and the brute-force closest
    hits, computed once per session: the brute force costs ~10 s and two test files share it."""
    from mcpt.shapes.bvh_build import build_bvh

    from .oracles import brute_force_closest_hit
    from mcpt.shapes.mesh import load_mesh

    mesh = load_mesh(shared_path("models", "stanford-bunny.obj"))
    tris = mesh.vertices[mesh.faces].astype(np.float32).astype(np.float64)
    bvh = build_bvh(tris)
    rng = np.random.default_rng(2024)
    lo, hi = tris.min(axis=(0, 1)), tris.max(axis=(0, 1))
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    u = rng.standard_normal((10_000, 3))
    origins = centre + radius * u / np.linalg.norm(u, axis=1, keepdims=True)
    dirs = lo + rng.random((10_000, 3)) * (hi - lo) - origins
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = origins.astype(np.float32).astype(np.float64)
    dirs = dirs.astype(np.float32).astype(np.float64)
    t_ref, i_ref = brute_force_closest_hit(tris, origins, dirs)
    return tris, bvh, origins, dirs, t_ref, i_ref
