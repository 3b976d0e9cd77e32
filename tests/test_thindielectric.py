"""Thin dielectric (issue #21; glsl/bsdf_thindielectric.glsl, mcpt/shading/thindielectric.py): the
reflect / pass choice against the summed reflectance (chi-square per angle, both sides), the
closed form against the series it sums, directions without refraction, weights, a furnace where
thin glass is exactly invisible, a window's transmittance, what compiles, bad input and the
Mitsuba mapping."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import load_scene, parse_scene
from mcpt.shading.materials import fresnel_dielectric
from mcpt.shading.thindielectric import reflectance
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .test_conductor import _err, _mat
from .test_materials_render import render
from .test_materials_util import chi2_test, floats, probe, sidak, uniform_numbers


def test_reflectance_is_the_sum_of_internal_reflections():
    """R' = R + T R T + T R^3 T + ... (the series summed term by term) for several indices."""
    cos = np.linspace(0.0, 1.0, 101)
    for ior in (1.2, 1.5, 2.4):
        r = fresnel_dielectric(np.maximum(cos, 1e-12), ior)
        t = 1.0 - r
        series = r + sum(t * r ** (2 * k + 1) * t for k in range(2000))
        np.testing.assert_allclose(reflectance(cos, ior), series, rtol=1e-9, atol=1e-12)
        assert np.all(reflectance(cos, ior) <= 1.0)


@pytest.mark.parametrize("ior,front", [(1.5, 1), (1.5, 0), (1.33, 1), (2.4, 0)])
def test_reflect_or_pass_follows_the_summed_reflectance(gl, ior, front):
    n = 1 << 15
    ps = []
    for deg in (0.0, 30.0, 60.0, 80.0, 89.0):
        t = math.radians(deg)
        wo = (math.sin(t), 0.0, math.cos(t))
        u = dict(type="thindielectric", albedo=(1, 1, 1), alpha=0.0, ior=ior, fdr_int=0.0, wo=wo, front=front)
        rnd = uniform_numbers(n, 2, seed=int(deg * 10 + ior * 1000 + front))
        out = probe(gl, "weight", rnd, **u)
        flags = out[:, 3]
        assert np.all(flags & 1) and np.all(flags & 2)  # valid, delta
        np.testing.assert_array_equal(floats(out)[:, :3], 1.0)  # every sample weighs 1
        np.testing.assert_array_equal(floats(probe(gl, "eta2", rnd, **u))[:, 0], 1.0)  # no refraction
        wi = floats(probe(gl, "sample", rnd, **u))[:, :3].astype(np.float64)
        refl = (flags & 4) == 0
        r = float(reflectance(math.cos(t), ior))
        p, _, _ = chi2_test([refl.sum(), (~refl).sum()], [r * n, (1 - r) * n], min_expected=0)
        ps.append(p)
        np.testing.assert_allclose(wi[refl], np.broadcast_to([-wo[0], 0.0, wo[2]], wi[refl].shape), atol=1e-6)
        np.testing.assert_allclose(wi[~refl], np.broadcast_to([-wo[0], 0.0, -wo[2]], wi[~refl].shape), atol=1e-6)
    print(f"ior {ior} front {front}: chi2 p {np.round(ps, 3)}")
    assert min(ps) > sidak(0.01, 4 * len(ps))


def test_thin_glass_in_a_uniform_emitter_is_exactly_invisible(gl):
    """Every sample weighs 1 and ends on the emitter (radiance 1): each pixel is exactly 1 (a path
    trapped for all 32 bounces has probability ~R'^32 < 1e-30)."""
    text = (ROOT / "scenes" / "furnace-glass.yaml").read_text().replace("    type: dielectric\n",
                                                                          "    type: thindielectric\n")
    scene = parse_scene(text, ROOT / "scenes" / "furnace-glass.yaml").with_overrides(resolution=(16, 16))
    res, f = render(gl, scene, 8, 3, russian_roulette=False)
    assert f.uses.thin_dielectric and not f.uses.dielectric and not f.uses.microfacet
    np.testing.assert_allclose(res.image, 1.0, rtol=2e-6)


def test_window_passes_one_minus_the_summed_reflectance(gl):
    """A narrow view through a pane (index 1.5, normal incidence) of an emitter of radiance 1: the
    pane passes T' = 1 - 2R/(1 + R) = 0.923 of it, unshifted (no refraction offset)."""
    quad = ROOT / "scenes" / "models" / "quad.obj"
    text = f"""
camera: {{position: [0, 0, 3], look_at: [0, 0, 0], vfov_deg: 2, resolution: [8, 8]}}
render: {{bounces: 4}}
materials:
  pane: {{type: thindielectric, ior: 1.5}}
  lamp: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
meshes:
  - {{file: {quad}, material: pane, transform: {{scale: 2}}}}
  - {{file: {quad}, material: lamp, transform: {{scale: 2, translate: [0, 0, -1]}}}}
"""
    res, _ = render(gl, parse_scene(text, ROOT / "scenes" / "inline.yaml"), 256, 4)
    img, var = res.image.astype(np.float64), res.variance.astype(np.float64)
    se = math.sqrt(var.sum()) / img.size
    want = 1.0 - float(reflectance(1.0, 1.5))
    print(f"window: {img.mean():.4f} +- {se:.4f}, T' = {want:.4f}")
    assert abs(img.mean() - want) < 4 * se + 1e-3


def test_compiled_only_when_used_and_bad_input(tmp_path):
    d = for_world(load_world(_mat("{type: thindielectric}"))).defines()
    assert d["MCPT_MAT_THIN_DIELECTRIC"] == d["MCPT_TRANSMISSION"] == d["MCPT_DELTA"] == 1
    assert d["MCPT_MAT_DIELECTRIC"] == 0
    assert for_world(load_world(_mat("{type: dielectric}"))).defines()["MCPT_MAT_THIN_DIELECTRIC"] == 0
    assert "ior 1 is no interface" in _err("{type: thindielectric, ior: 1}")
    assert "thindielectric material has no roughness" in _err("{type: thindielectric, roughness: 0.1}")
    from .test_mitsuba import write_xml

    body = """<shape type="rectangle"><bsdf type="thindielectric"><string name="int_ior" value="water"/></bsdf></shape>
    <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"""
    m = [m for m in load_scene(write_xml(tmp_path, body)).materials.values() if m.type == "thindielectric"]
    assert len(m) == 1 and abs(m[0].ior - 1.333 / 1.000277) < 1e-9
    # Refused before issue #22; mapped now (tests/test_specular_weights.py).
    m = load_scene(write_xml(tmp_path, '<shape type="sphere"><bsdf type="thindielectric">'
                                       '<rgb name="specular_transmittance" value="0.5"/></bsdf></shape>'))
    assert [x.specular_transmittance for x in m.materials.values()] == [(0.5, 0.5, 0.5)]
