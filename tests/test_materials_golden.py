"""Statistical golden images of the material scenes (issue #3), judged like the other goldens
(mcpt/golden.py: per-pixel z-test against a reference mean and per-sample variance, Sidak-
corrected, >= 99.75 % of pixel-channels must accept, image mean within 4 standard errors).

The specs live here rather than in mcpt.golden.GOLDENS because two of them clamp (below), which
golden.render_spec does not do; the files have golden.py's format. Regenerate them with

    MCPT_UPDATE_GOLDEN=1 .venv/bin/python -m pytest -q tests/test_materials_golden.py

Caustics (light reaching a diffuse wall off a mirror, through glass or off the gold, found only
by BSDF sampling) are rare samples (~1e-4 per pixel sample) of large value (~10): a 4096-spp
reference holds too few of them to estimate their variance, and a 64-spp test that draws one
is 10-20 standard errors off. So, for those two scenes, the reference and the test both clamp
each sample's largest component at CLAMP[name]. That changes what is estimated (a clamped
image), but identically on both sides, so the test still compares like with like: a clamped
caustic sample moves its pixel by ~1 standard error, and every other difference (a wrong BSDF,
texture or normal, a bias) shows as before. The Spot has no caustics and is not clamped.
"""

import datetime as dt
import os

import numpy as np
import pytest

from mcpt import __version__, golden
from mcpt.loader import load_world
from mcpt.scene import load_scene

from .conftest import ROOT
from .test_materials_util import renderer

CLAMP = {"cornell-spheres": 1.0, "bunny-metal": 1.0, "spot": None}
SPECS = {s.name: s for s in (
    # mirror and glass spheres with smooth normals
    golden.GoldenSpec("cornell-spheres", "scenes/cornell-spheres.yaml", (32, 32), 4096, 2_000_003, 64, 17, 6),
    # rough gold, 69k triangles
    golden.GoldenSpec("bunny-metal", "scenes/bunny-metal.yaml", (32, 32), 4096, 2_000_004, 64, 18, 4),
    # albedo texture and smooth normals
    golden.GoldenSpec("spot", "scenes/spot.yaml", (32, 32), 4096, 2_000_005, 64, 19, 4),
)}


def render_spec(gl, spec, spp, seed):
    scene = load_scene(ROOT / spec.scene).with_overrides(resolution=spec.resolution, bounces=spec.bounces)
    world = load_world(scene)
    clamp = CLAMP[spec.name]
    feats = world.features(variance=True, clamp=clamp is not None)
    r = renderer(gl, world, feats)
    try:
        res = r.render(spp, seed, clamp=clamp)
    finally:
        r.release()
    meta = {
        "name": spec.name, "scene": spec.scene, "scene_sha256": golden.scene_digest(ROOT / spec.scene),
        "resolution": list(spec.resolution), "spp": spp, "seed": seed, "bounces": res.bounces,
        "clamp": clamp, "dropped_samples": res.dropped_samples, "gl_backend": gl.backend,
        "gl_renderer": gl.renderer, "gl_version": gl.version, "mcpt_version": __version__,
        "render_seconds": round(res.render_seconds, 3),
        "created": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
    }
    return res.image, res.variance * np.float32(spp), meta


@pytest.mark.parametrize("name", list(SPECS))
def test_scene_matches_its_golden_image(gl, name):
    spec = SPECS[name]
    path = golden.golden_path(name)
    if os.environ.get("MCPT_UPDATE_GOLDEN") == "1":
        mean, var, meta = render_spec(gl, spec, spec.ref_spp, spec.ref_seed)
        assert meta["dropped_samples"] == 0
        golden.save(path, mean, var, meta)
    assert path.is_file(), f"no golden at {path}: run with MCPT_UPDATE_GOLDEN=1"
    g = golden.load(path)
    assert g.meta["scene_sha256"] == golden.scene_digest(ROOT / spec.scene), \
        f"{path} is stale ({spec.scene} changed): run with MCPT_UPDATE_GOLDEN=1"
    assert g.meta["clamp"] == CLAMP[name]
    seed = spec.test_seed + int(os.environ.get("MCPT_TEST_SEED", "0"))
    mean, _, meta = render_spec(gl, spec, spec.test_spp, seed)
    assert meta["dropped_samples"] == 0
    result = golden.compare(spec, g, mean, spec.test_spp)
    if not result.passed:
        golden.write_report(ROOT / "out" / "golden" / gl.backend, name, mean, g.mean, result)
    assert result.passed, f"{name}: {result.summary()}"
