"""The environment (issue #20): a furnace under a constant sky, through the real path tracer."""

import numpy as np
import pytest

from mcpt.scene import SceneError, parse_scene

from .conftest import ROOT
from .test_lights import render

RHO, SKY = np.array([0.5, 0.7, 0.3]), np.array([1.0, 2.0, 3.0])


def sky_scene(env: str = "{radiance: [1, 2, 3]}"):
    text = f"""
camera: {{position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 40, resolution: [24, 24]}}
render: {{bounces: 4}}
materials:
  m: {{albedo: [0.5, 0.7, 0.3]}}
meshes:
  - file: models/icosphere.obj
    material: m
environment: {env}
"""
    return parse_scene(text, ROOT / "scenes" / "inline.yaml")


@pytest.mark.parametrize("sampling", ["mis", "nee", "bsdf"])
def test_convex_diffuse_object_under_a_constant_sky_is_rho_l(gl, sampling):
    """A convex object never sees itself: every pixel on it has radiance rho L (each of the three
    estimators, within noise), every pixel beside it the sky's L exactly."""
    res, feats = render(gl, sky_scene(), 64, 11, sampling=sampling)
    assert feats.defines()["MCPT_LIGHT_ENV"] == 1 and feats.defines()["MCPT_LIGHT_AREA"] == 0
    inner = slice(8, 16)  # fully on the sphere (radius ~8.2 pixels about the centre)
    on = res.image[inner, inner].reshape(-1, 3)
    se = np.sqrt(res.variance[inner, inner].reshape(-1, 3).mean(0) / len(on))
    # (BSDF sampling is exact here: cosine-weighted directions of a constant sky, zero variance)
    z = (on.mean(0) - RHO * SKY) / (se + 1e-5 * RHO * SKY)
    assert np.all(np.abs(z) < 4), (on.mean(0), z)
    np.testing.assert_allclose(res.image[:2, :2].reshape(-1, 3), np.broadcast_to(SKY, (4, 3)), rtol=1e-6)


def test_an_invisible_sky_still_lights_the_scene(gl):
    res, _ = render(gl, sky_scene("{radiance: [1, 2, 3], visible: false}"), 16, 12)
    assert np.all(res.image[:2, :2] == 0.0)
    assert res.image[12, 12] == pytest.approx(RHO * SKY, rel=0.1)


def test_zero_sky_is_refused_with_its_line():
    with pytest.raises(SceneError, match=r"inline.yaml:9: environment.radiance: radiance is zero"):
        sky_scene("{radiance: [0, 0, 0]}")
