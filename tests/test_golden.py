"""Golden images of the shipped scenes, judged statistically (tests/goldens.py, issue #6).

Each golden in tests/golden/ is a reference mean and per-sample variance made with 4096 spp;
the test renders the scene FRESH with another seed and few samples and runs the per-pixel
z-test with a Sidak-corrected threshold (>= 99.75 % of pixel-channels must accept, image mean
within 4 standard errors). On failure the test, reference, difference and |z| images are
written to out/golden/<backend>/ (or $MCPT_GOLDEN_REPORT_DIR). Regenerate with `make goldens`.
CI runs this file on EGL and on OSMesa (.ci/run).
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

from tests import goldens as golden

from .conftest import ROOT


def report_dir(gl) -> str:
    return os.environ.get("MCPT_GOLDEN_REPORT_DIR") or str(ROOT / "out" / "golden" / gl.backend)


@pytest.fixture(scope="module", params=["sobol", "independent"])
def fresh(gl, request):
    """One fresh render per golden (the spec's test spp and seed), shared by the tests below;
    once with each sampler (both must be unbiased)."""
    out = {}
    for name, spec in golden.GOLDENS.items():
        mean, _, meta = golden.render_spec(spec, spec.test_spp, spec.test_seed, sampler=request.param)
        out[name] = (mean, meta)
    return out


@pytest.mark.parametrize("name", list(golden.GOLDENS))
def test_fresh_render_matches_the_golden(name, gl, fresh):
    spec = golden.GOLDENS[name]
    path = golden.golden_path(name)
    assert path.is_file(), f"no golden at {path}: run `make goldens`"
    g = golden.load(path)
    assert g.meta["scene_sha256"] == golden.scene_digest(ROOT / spec.scene), \
        f"{path} is stale ({spec.scene} changed): run `make goldens`"
    mean, meta = fresh[name]
    assert meta["seed"] != g.meta["seed"]
    assert meta["dropped_samples"] == 0
    assert g.meta.get("clamp") == spec.clamp  # a clamped image is only comparable with one
    result = golden.compare(spec, g, mean, spec.test_spp)
    if not result.passed:
        golden.write_report(report_dir(gl), name, mean, g.mean, result)
    assert result.passed, (f"{name} ({meta['sampler']}) on {gl.renderer} ({gl.backend}), golden made on "
                           f"{g.meta['gl_renderer']} ({g.meta['gl_backend']}): {result.summary()}")


@pytest.mark.parametrize("name", list(golden.GOLDENS))
def test_golden_metadata(name):
    g = golden.load(golden.golden_path(name))
    spec = golden.GOLDENS[name]
    for key in ("gl_renderer", "gl_version", "gl_backend", "spp", "seed", "mcpt_version",
                "scene_sha256", "resolution", "bounces", "created"):
        assert key in g.meta, key
    assert g.mean.shape == g.var.shape == (spec.resolution[1], spec.resolution[0], 3)
    assert g.mean.dtype == np.float32 and np.isfinite(g.mean).all() and (g.var >= 0).all()
    assert g.meta["spp"] >= 64 * spec.test_spp  # the reference's own noise is negligible
    assert g.meta["seed"] != spec.test_seed


def test_the_test_catches_a_small_global_bias_and_a_local_defect(fresh, tmp_path):
    """Power: 3 % too bright everywhere, or one 4x4 patch black, must fail (and write images)."""
    spec = golden.GOLDENS["cornell-box"]
    g = golden.load(golden.golden_path("cornell-box"))
    mean = fresh["cornell-box"][0]
    assert golden.compare(spec, g, mean, spec.test_spp).passed
    bright = golden.compare(spec, g, mean * np.float32(1.03), spec.test_spp)
    assert not bright.passed and "image mean" in bright.reason
    hole = mean.copy()
    hole[30:34, 30:34] = 0.0
    local = golden.compare(spec, g, hole, spec.test_spp)
    assert not local.passed and "rejected" in local.reason
    files = golden.write_report(tmp_path, "cornell-box", hole, g.mean, local)
    assert len(files) == 5 and all(os.path.getsize(f) > 0 for f in files)
    nan = mean.copy()
    nan[0, 0, 0] = np.nan
    assert "non-finite" in golden.compare(spec, g, nan, spec.test_spp).reason


def test_sidak_threshold():
    assert golden.sidak_alpha(0.01, 1) == pytest.approx(0.01)
    assert golden.z_threshold(0.01) == pytest.approx(2.5758, abs=1e-4)
    n = 64 * 64 * 3
    a = golden.sidak_alpha(0.01, n)
    assert 1 - (1 - a) ** n == pytest.approx(0.01, rel=1e-9)
    assert golden.z_threshold(a) == pytest.approx(4.93, abs=0.01)


def test_a_stale_or_missing_golden_says_how_to_regenerate(tmp_path):
    r = golden.check("furnace", directory=tmp_path)
    assert not r.passed and "make goldens" in r.reason
    shutil.copy(golden.golden_path("furnace"), tmp_path / "furnace.npz")
    g = golden.load(tmp_path / "furnace.npz")
    golden.save(tmp_path / "furnace.npz", g.mean, g.var, {**g.meta, "scene_sha256": "0" * 64})
    r = golden.check("furnace", directory=tmp_path)
    assert not r.passed and "make goldens" in r.reason


def test_regeneration_command_writes_a_loadable_golden(tmp_path, gl):
    assert golden.main(["furnace", "--spp", "2", "--dir", str(tmp_path)]) == 0
    g = golden.load(tmp_path / "furnace.npz")
    assert g.meta["spp"] == 2 and g.meta["gl_renderer"] == gl.renderer
    assert g.meta["gl_backend"] == gl.backend
