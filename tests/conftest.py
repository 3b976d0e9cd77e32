import os
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
# Everything the tests read is in the repository (tests/data/README.md says what and from where).
DATA = ROOT / "tests" / "data"
MODELS = ROOT / "scenes" / "models"
BUNNY = MODELS / "stanford-bunny.obj"
SPOT = MODELS / "spot" / "spot_triangulated.obj"
SPOT_TEXTURE = MODELS / "spot" / "spot_texture.png"
SUZANNE = DATA / "models" / "suzanne.obj"
CORNELL = ROOT / "scenes" / "cornell"             # the shipped Cornell box meshes
CORNELL_REF = DATA / "scenes-ref" / "cornell"   # scene.json, the OBJs, Mitsuba's reference.exr
FURNACE_REF = DATA / "scenes-ref" / "furnace"   # scene.json with the analytic values

# mcpt.bench reads reference scenes from $MCPT_SHARED: the session's bench runs read tests/data.
os.environ["MCPT_SHARED"] = str(DATA)
# The set-up cache (mcpt/cache.py) of the test session lives in a folder of its own, never in the
# user's cache: tests see cold and warm set-ups of their own making only.
os.environ["MCPT_CACHE_DIR"] = tempfile.mkdtemp(prefix="mcpt-test-cache-")


@pytest.fixture(scope="session")
def gl():
    """The GL context of the back end under test (MCPT_GL_BACKEND: egl, osmesa; default auto)."""
    from mcpt.gpu.context import shared_context

    return shared_context(os.environ.get("MCPT_GL_BACKEND"))


def data_path(*parts) -> Path:
    """A file of tests/data (``data_path("scenes-ref", "cornell", "reference.exr")``); missing is
    an error, never a skip."""
    p = DATA.joinpath(*parts)
    if not p.exists():
        raise FileNotFoundError(f"test data missing: {p}")
    return p


shared_path = data_path  # the former name, still imported by tests/test_render.py


@lru_cache(maxsize=1)
def bunny_reference():
    """Bunny triangles, its BVH, 10^4 rays (float32-representable) and the brute-force closest
    hits, computed once per session: the brute force costs ~10 s and two test files share it."""
    from mcpt.shapes.bvh_build import build_bvh
    from mcpt.shapes.mesh import load_mesh

    from .oracles import brute_force_closest_hit

    mesh = load_mesh(BUNNY)
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
