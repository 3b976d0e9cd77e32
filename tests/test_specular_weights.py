"""Specular weights (issue #22; mcpt/shading/specular_weights.py, SPEC_R / SPEC_T in
glsl/materials.glsl): Mitsuba 3's ``specular_reflectance`` / ``specular_transmittance`` on the glasses
and the plastics' coat. Factor 1 is today's material (nothing compiled, the same pixels, also with
the feature compiled in); a factor scales its lobe's value and weight and leaves the lobe choice and
the pdf alone (the GLSL BSDFs against themselves at factor 1 and the float64 twin); panes in a
constant environment against the closed form; a texture equals its constant; the YAML keys and the
Mitsuba mapping (refused before)."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import SceneError, load_scene, parse_scene
from mcpt.shading import microfacet as MF
from mcpt.shading.materials import fresnel_dielectric
from mcpt.shading.roughdielectric import bsdf as twin
from mcpt.shading.thindielectric import reflectance
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .test_conductor import _err, _mat
from .test_materials_render import SEED_OFFSET, render
from .test_materials_util import floats, probe, renderer, uniform_numbers
from .test_mitsuba import write_xml

R = (0.9, 0.5, 0.1)
T = (0.2, 0.6, 1.0)
W30 = (0.5, 0.0, 0.8660254)
W70 = (0.9396926, 0.0, 0.3420201)


# --- the BSDFs (tests/glsl/probe_sample.frag) ----------------------------------------------------

@pytest.mark.parametrize("kind", ["dielectric", "thindielectric", "plastic"])
@pytest.mark.parametrize("wo,front", [(W70, 1), (W30, 0)])
def test_delta_lobes_scale_by_their_factor_and_keep_the_fresnel_choice(gl, kind, wo, front):
    n = 1 << 14
    u = dict(type=kind, albedo=(0.5, 0.5, 0.5), alpha=0.0, ior=1.5, fdr_int=0.6, wo=wo, front=front)
    rnd = uniform_numbers(n, 3, seed=int(1000 * wo[0]) + front)
    plain = probe(gl, "weight", rnd, **u)
    tinted = probe(gl, "weight", rnd, **u, spec_r=R, spec_t=T)
    np.testing.assert_array_equal(tinted[:, 3], plain[:, 3])  # the same lobes (valid, delta, transmit)
    np.testing.assert_array_equal(probe(gl, "sample", rnd, **u, spec_r=R, spec_t=T), probe(gl, "sample", rnd, **u))
    flags = plain[:, 3]
    refl, trans = (flags & 6) == 2, (flags & 4) != 0  # delta reflection; transmission
    w0, w1 = floats(plain)[:, :3], floats(tinted)[:, :3]
    assert refl.any() and (trans.any() or kind == "plastic")
    np.testing.assert_array_equal(w1[refl], w0[refl] * np.float32(R))
    np.testing.assert_array_equal(w1[trans], w0[trans] * np.float32(T))
    other = ~refl & ~trans  # the plastic's diffuse lobe: no factor
    np.testing.assert_array_equal(w1[other], w0[other])
    if kind == "dielectric":  # weights R and T / eta^2 exactly
        eta = 1.5 if front else 1 / 1.5
        np.testing.assert_allclose(w1[trans], np.broadcast_to(np.float32(T) / eta**2, w1[trans].shape), rtol=1e-6)
        np.testing.assert_array_equal(w1[refl], np.broadcast_to(np.float32(R), w1[refl].shape))
        f = float(fresnel_dielectric(wo[2], eta))
        assert abs(refl.mean() - f) < 5 * math.sqrt(f * (1 - f) / n) + 1e-4


@pytest.mark.parametrize("dist", MF.DISTRIBUTIONS)
@pytest.mark.parametrize("wo,front", [(W30, 1), (W70, 0)])
def test_rough_glass_value_pdf_and_weight_against_the_twin(gl, dist, wo, front):
    """f |cos| = twin x the lobe's factor per channel (reflected: spec_r, refracted: spec_t); the
    pdf unchanged; each sample's weight = the plain weight x its lobe's factor = f / pdf."""
    u = dict(type="roughdielectric", albedo=(1, 1, 1), alpha=0.3, ior=1.5, fdr_int=0.0, wo=wo, front=front,
             flags=MF.flags(dist, "separable"))
    rng = np.random.default_rng(3)
    wi = rng.normal(size=(4096, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    eta = 1.5 if front else 1 / 1.5
    ev0 = floats(probe(gl, "eval_t", wi.astype(np.float32), **u)).astype(np.float64)
    ev1 = floats(probe(gl, "eval_t", wi.astype(np.float32), **u, spec_r=R, spec_t=T)).astype(np.float64)
    factor = np.where(wi[:, 2:3] > 0, R, T)
    want = twin(np.asarray(wo), wi, eta, 0.3, dist, "separable")[:, None] * factor
    np.testing.assert_allclose(ev1[:, :3], want, rtol=3e-3, atol=1e-5 * want.max())
    np.testing.assert_array_equal(ev1[:, 3], ev0[:, 3])  # pdf
    rnd = uniform_numbers(4096, 3, seed=11 + front)
    plain, tinted = probe(gl, "weight", rnd, **u), probe(gl, "weight", rnd, **u, spec_r=R, spec_t=T)
    np.testing.assert_array_equal(tinted[:, 3], plain[:, 3])
    ok, trans = (plain[:, 3] & 1) != 0, (plain[:, 3] & 4) != 0
    lobe = np.where(trans[:, None], np.float32(T), np.float32(R))
    np.testing.assert_allclose(floats(tinted)[ok, :3], floats(plain)[ok, :3] * lobe[ok], rtol=1e-6)
    wi_s = floats(probe(gl, "sample", rnd, **u))[ok, :3]
    ev_s = floats(probe(gl, "eval_t", wi_s, **u, spec_r=R, spec_t=T))
    np.testing.assert_allclose(floats(tinted)[ok, :3], ev_s[:, :3] / ev_s[:, 3:4], rtol=3e-3)


# --- renders -------------------------------------------------------------------------------------

def _pane(kind: str, extra: str = "", ior: float = 1.5):
    """A pane (quad) seen at normal incidence through a 2-degree camera, in a constant environment of
    radiance 1: one interaction, then the environment."""
    quad = ROOT / "scenes" / "models" / "quad.obj"
    text = f"""
camera: {{position: [0, 0, 3], look_at: [0, 0, 0], vfov_deg: 2, resolution: [8, 8]}}
render: {{bounces: 4}}
environment: {{radiance: [1, 1, 1]}}
materials:
  pane: {{type: {kind}, ior: {ior}{extra}}}
meshes:
  - {{file: {quad}, material: pane, transform: {{scale: 2}}}}
"""
    return parse_scene(text, ROOT / "scenes" / "inline.yaml")


@pytest.mark.parametrize("kind", ["thindielectric", "dielectric"])
def test_pane_in_an_environment_is_the_closed_form(gl, kind):
    """Thin: R' spec_r + (1 - R') spec_t (R' the pane's summed reflectance); a single smooth
    interface: F spec_r + (1 - F) spec_t / eta^2 (the refracted radiance compressed), per channel."""
    extra = f", specular_reflectance: {list(R)}, specular_transmittance: {list(T)}"
    res, f = render(gl, _pane(kind, extra), 512, 5)
    assert f.defines()["MCPT_SPECULAR_WEIGHTS"] == 1
    r = float(reflectance(1.0, 1.5)) if kind == "thindielectric" else float(fresnel_dielectric(1.0, 1.5))
    t = 1.0 - r if kind == "thindielectric" else (1.0 - r) / 1.5**2
    want = r * np.asarray(R) + t * np.asarray(T)
    img, var = res.image.astype(np.float64), res.variance.astype(np.float64)
    mean = img.reshape(-1, img.shape[-1])[:, :3].mean(0)
    se = np.sqrt(var.reshape(-1, var.shape[-1])[:, :3].sum(0)) / (img.shape[0] * img.shape[1])
    z = (mean - want) / np.maximum(se, 1e-9)
    print(f"{kind}: mean {np.round(mean, 4)} want {np.round(want, 4)} z {np.round(z, 2)}")
    assert np.all(np.abs(z) < 4), (mean, want, se)


def _pixels(gl, scene, force: bool = False):
    world = load_world(scene)
    feats = for_world(world, bounces=8, variance=False)
    if force:
        feats = feats.replace(specular_weights=True)
    r = renderer(gl, world, feats)
    try:
        return draw(r, 16, 3 + SEED_OFFSET).image, feats
    finally:
        r.release()


@pytest.mark.parametrize("kind", ["dielectric", "roughdielectric", "thindielectric", "plastic", "roughplastic"])
def test_factor_one_is_todays_material_bit_for_bit(gl, kind):
    """Factors of 1 (Mitsuba's default, spelled out) compile nothing and change no pixel; the
    program with the feature compiled in (every factor 1 in the table) renders the same pixels."""
    rough = ", roughness: 0.2" if kind.startswith("rough") else ""
    keys = ", specular_reflectance: 1" + (", specular_transmittance: [1, 1, 1]" if "dielectric" in kind else "")
    base, f0 = _pixels(gl, _mat(f"{{type: {kind}{rough}}}"))
    same, f1 = _pixels(gl, _mat(f"{{type: {kind}{rough}{keys}}}"))
    forced, f2 = _pixels(gl, _mat(f"{{type: {kind}{rough}}}"), force=True)
    assert f0.defines()["MCPT_SPECULAR_WEIGHTS"] == f1.defines()["MCPT_SPECULAR_WEIGHTS"] == 0
    assert f2.defines()["MCPT_SPECULAR_WEIGHTS"] == 1 and f2.material_texels == f0.material_texels + 2
    assert base.max() > 0
    np.testing.assert_array_equal(same, base)
    np.testing.assert_array_equal(forced, base)


def _png(path, rgb, size=4):
    import cv2

    img = np.zeros((size, size, 3), np.uint8)
    img[:] = rgb
    cv2.imwrite(str(path), img[:, :, ::-1])
    return path


def test_a_texture_is_its_colour_srgb_decoded(gl, tmp_path):
    """An 8-bit image (sRGB-decoded, as Mitsuba's bitmap raw=false) replaces the constant: a
    uniform image renders as its decoded colour given as a constant (the same lobes, the same seed)."""
    code = (200, 128, 30)
    lin = [(c / 255 / 12.92) if c / 255 <= 0.04045 else ((c / 255 + 0.055) / 1.055) ** 2.4 for c in code]
    png = _png(tmp_path / "tint.png", code)
    img_t, f = _pixels(gl, _pane("thindielectric", f", specular_transmittance: {{file: {png}, filter: nearest}}"))
    img_c, _ = _pixels(gl, _pane("thindielectric", f", specular_transmittance: {lin}"))
    assert f.defines()["MCPT_TEXTURES"] == f.defines()["MCPT_SPECULAR_WEIGHTS"] == 1
    np.testing.assert_allclose(img_t, img_c, rtol=2e-5, atol=1e-7)
    assert img_c[..., 2].mean() < img_c[..., 0].mean()


# --- scene input ---------------------------------------------------------------------------------

def test_yaml_keys_by_type():
    assert "a plastic material has no specular_transmittance" in _err("{type: plastic, specular_transmittance: 0.5}")
    assert "a diffuse material has no specular_reflectance" in _err("{type: diffuse, specular_reflectance: 0.5}")
    assert "less than or equal to 1" in _err("{type: dielectric, specular_transmittance: [0.5, 1.5, 0.5]}")
    m = _mat("{type: roughdielectric, roughness: 0.1, specular_reflectance: 0.5}").materials["m"]
    assert m.specular_reflectance == (0.5, 0.5, 0.5) and m.specular_transmittance is None


def test_mitsuba_factors_are_mapped(tmp_path):
    """Refused before issue #22 ("specular_transmittance is not supported"): colours and bitmaps map
    onto the YAML keys; out of [0, 1] is one located line."""
    _png(tmp_path / "t.png", (10, 20, 30))
    body = """<shape type="sphere"><bsdf type="dielectric"><rgb name="specular_transmittance" value="0.9, 0.6, 0.3"/>
    </bsdf></shape>
    <shape type="sphere"><bsdf type="roughdielectric"><float name="specular_reflectance" value="0.5"/></bsdf></shape>
    <shape type="sphere"><bsdf type="thindielectric"><texture type="bitmap" name="specular_reflectance">
    <string name="filename" value="t.png"/></texture></bsdf></shape>
    <shape type="sphere"><bsdf type="roughplastic"><rgb name="specular_reflectance" value="0.25"/></bsdf></shape>"""
    mats = {m.type: m for m in load_scene(write_xml(tmp_path, body)).materials.values()}
    assert mats["dielectric"].specular_transmittance == (0.9, 0.6, 0.3)
    assert mats["dielectric"].specular_reflectance is None
    assert mats["roughdielectric"].specular_reflectance == (0.5, 0.5, 0.5)
    assert mats["thindielectric"].specular_reflectance.file.name == "t.png"
    assert mats["roughplastic"].specular_reflectance == (0.25, 0.25, 0.25)
    bad = '<shape type="sphere"><bsdf type="dielectric"><rgb name="specular_reflectance" value="1.5"/></bsdf></shape>'
    with pytest.raises(SceneError, match=r"s\.xml:\d+: .*specular_reflectance .* out of \[0, 1\]"):
        load_scene(write_xml(tmp_path, bad))


def test_rough_plastic_coat_scales_and_the_base_does_not(gl):
    """Rough plastic: f = spec_r x coat + base (Mitsuba's roughplastic eval); pdf unchanged."""
    from .test_roughplastic import _material

    rng = np.random.default_rng(5)
    wi = rng.normal(size=(2048, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wi = wi.astype(np.float32)
    u, tbos, _, _ = _material("ggx", 0.2, W30, (0.4, 0.3, 0.2), False)
    black, btbos, _, _ = _material("ggx", 0.2, W30, (0.0, 0.0, 0.0), False)
    coat0 = floats(probe(gl, "eval", wi, tbos=btbos, **black)).astype(np.float64)
    coat1 = floats(probe(gl, "eval", wi, tbos=btbos, **black, spec_r=R)).astype(np.float64)
    np.testing.assert_allclose(coat1[:, :3], coat0[:, :3] * np.asarray(R), rtol=1e-6, atol=1e-12)
    f0 = floats(probe(gl, "eval", wi, tbos=tbos, **u)).astype(np.float64)
    f1 = floats(probe(gl, "eval", wi, tbos=tbos, **u, spec_r=R)).astype(np.float64)
    base = f0[:, :3] - coat0[:, :3]
    np.testing.assert_allclose(f1[:, :3], base + coat0[:, :3] * np.asarray(R), rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(f1[:, 3], f0[:, 3])
    assert coat0[:, :3].max() > 0 and base.max() > 0


def test_specular_weights_sit_after_a_metal_rough_rows_fifth_texel(gl):
    """Both texel-4 users and the specular weights in one table (the layouts of issues #21 and #22
    merged): a metal-rough row's F0, F90 stay in texel 4, the weights move to 5-6, pixels unchanged."""
    mat = _mat("{type: metalrough, albedo: [0.8, 0.5, 0.3], metallic: 0.0, roughness: 0.4, ior: 1.7}")
    base, f0 = _pixels(gl, mat)
    forced, f1 = _pixels(gl, mat, force=True)
    assert f0.defines()["MCPT_METALROUGH_SPECULAR"] == 1 and f0.material_texels == 5
    assert f1.defines()["MCPT_SPEC_TEXEL"] == 5 and f1.material_texels == 7
    assert base.max() > 0
    np.testing.assert_array_equal(forced, base)
