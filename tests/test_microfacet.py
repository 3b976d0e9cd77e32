"""Microfacet distributions and masking terms (issue #21; mcpt/shading/microfacet.py,
glsl/bsdf_microfacet.glsl): chi-square of the real GLSL sampling for Beckmann and GGX with either
masking term, the BRDF against independent float64 twins, reciprocity, energy (white furnace and
single-scattering albedo by quadrature), what compiles, and the Mitsuba reader's exact mapping."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import SceneError, load_scene
from mcpt.shading import microfacet as MF
from mcpt.shading.materials import FRESNEL, FRESNEL_SHIFT
from mcpt.shapes.world import load_world

from . import test_sampling as ts
from .test_conductor import _err, _mat
from .test_materials_render import furnace, render
from .test_materials_util import floats, probe, uniform_numbers

NONE = FRESNEL["none"] << FRESNEL_SHIFT
BECK, SEP = MF.FLAG_BECKMANN, MF.FLAG_SEPARABLE
WOS = [(0.0, 0.0, 1.0), (0.7071068, 0.0, 0.7071068), (0.0, 0.9396926, 0.3420201)]  # 0, 45, 70 deg


def _u(alpha, wo, flags=0):
    return dict(type="conductor", albedo=(1, 1, 1), alpha=alpha, wo=wo, flags=NONE | flags)


CHI2 = [(f"{d}-{alpha}-{i}", _u(alpha, WOS[i], fl))
        for d, fl in (("beckmann", BECK), ("ggx-separable", SEP), ("beckmann-separable", BECK | SEP))
        for alpha, i in ((0.05, 1), (0.3, 0), (0.3, 2), (0.8, 1))]


@pytest.mark.parametrize("name,u", CHI2, ids=[c[0] for c in CHI2])
def test_sampling_matches_its_pdf(gl, name, u):
    """tests/test_sampling.py's chi-square (cells over the sphere, the GLSL pdf integrated per
    cell), and the sample's pdf and weight against bsdf_eval."""
    p = ts.bsdf_sampling_p(gl, name, ts._uniforms(u))
    assert p > ts.ALPHA, f"{name}: chi2 p = {p:.3g} < {ts.ALPHA:.3g}"


def _twin(wo, wi, alpha, dist, masking):
    """f |cos wi| with F = 1, in float64 from mcpt/shading/microfacet.py."""
    h = wo + wi
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    g = MF.G2(MF.LAMBDA[dist](wo, alpha), MF.LAMBDA[dist](wi, alpha), masking)
    return np.where(wi[..., 2] > 0, MF.D[dist](h, alpha) * g / (4 * wo[..., 2]), 0.0)


@pytest.mark.parametrize("dist", MF.DISTRIBUTIONS)
@pytest.mark.parametrize("masking", MF.MASKINGS)
def test_brdf_is_the_twin_and_reciprocal(gl, dist, masking):
    fl = (BECK if dist == "beckmann" else 0) | (SEP if masking == "separable" else 0)
    rng = np.random.default_rng(21)
    wi = rng.normal(size=(4096, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wi[:, 2] = np.abs(wi[:, 2]) + 0.02
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    for alpha in (0.05, 0.3, 0.8):
        for wo in WOS[1:]:
            o = np.asarray(wo, np.float64)
            f = floats(probe(gl, "eval", wi.astype(np.float32), **_u(alpha, wo, fl)))[:, 0].astype(np.float64)
            want = _twin(np.broadcast_to(o, wi.shape), wi, alpha, dist, masking)
            np.testing.assert_allclose(f, want, rtol=2e-3, atol=1e-6 * want.max())
            # Reciprocity: f(wo, wi) = f(wi, wo), i.e. (f |cos wi|) / cos wi is symmetric.
            back = np.array([floats(probe(gl, "eval", o[None].astype(np.float32), **_u(alpha, tuple(w), fl)))[0, 0]
                             for w in wi[:64]], np.float64)
            np.testing.assert_allclose(f[:64] / wi[:64, 2], back / o[2], rtol=3e-3, atol=1e-6 * want.max())


def _albedo(wo, alpha, dist, masking, n=1024):
    """Directional albedo with F = 1 by quadrature over the half vector (d wi = 4 |wo.h| d h):
    the integral of D(h) G2 (wo.h) / wo.z, theta_h = atan(alpha tan(pi v / 2)) on midpoints v
    (dense where D is), phi on midpoints."""
    v = (np.arange(n) + 0.5) / n
    th = np.arctan(alpha * np.tan(0.5 * np.pi * v))
    dth = alpha * 0.5 * np.pi / np.cos(0.5 * np.pi * v) ** 2 / (1 + (alpha * np.tan(0.5 * np.pi * v)) ** 2) / n
    ph = (np.arange(n) + 0.5) / n * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
    o = np.broadcast_to(np.asarray(wo, np.float64), h.shape)
    oh = (o * h).sum(-1)
    i = 2 * oh[..., None] * h - o
    ok = (oh > 0) & (i[..., 2] > 0)
    i[..., 2] = np.where(ok, i[..., 2], 1.0)
    g = MF.G2(MF.LAMBDA[dist](o, alpha), MF.LAMBDA[dist](i, alpha), masking)
    val = np.where(ok, MF.D[dist](h, alpha) * g * oh / o[..., 2], 0.0)
    return float((val * np.sin(T) * dth[:, None]).sum() * (2 * np.pi / n))


@pytest.mark.parametrize("dist", MF.DISTRIBUTIONS)
@pytest.mark.parametrize("masking", MF.MASKINGS)
def test_energy_is_the_single_scattering_albedo(gl, dist, masking):
    """With F = 1 the mean sample weight is the single-scattering albedo (quadrature of the twin):
    <= 1, its deficit what masking removes; the separable term never gains over the correlated."""
    fl = (BECK if dist == "beckmann" else 0) | (SEP if masking == "separable" else 0)
    for alpha in (0.05, 0.3, 0.8):
        for wo in WOS:
            w = floats(probe(gl, "weight", uniform_numbers(1 << 17, 2, int(alpha * 100)),
                             **_u(alpha, wo, fl)))[:, 0].astype(np.float64)
            e = _albedo(wo, alpha, dist, masking)
            se = w.std() / math.sqrt(w.size)
            assert abs(w.mean() - e) < 4 * se + 3e-3, (alpha, wo, w.mean(), e)
            assert e <= 1.0 + 1e-3 and w.mean() <= 1.0 + 4 * se
            if masking == "separable":
                assert e <= _albedo(wo, alpha, dist, "height_correlated") + 1e-9


def test_white_beckmann_furnace_loses_only_masked_energy(gl):
    """An emitting white (F = 1) rough enclosure: each bounce keeps at most what it got (the image
    mean <= bounces + 1 within noise) and alpha 0.1 Beckmann loses ~0.5 % per bounce (inside a
    sphere most bounces are near normal incidence: the quadrature above gives 0.998 there)."""
    res, f = render(gl, furnace("{type: conductor, fresnel: none, roughness: 0.1, distribution: beckmann, "
                                "masking: separable, emission: [1, 1, 1]}", bounces=4), 32, 3,
                    russian_roulette=False)
    assert f.uses.beckmann and f.uses.separable_masking
    img = res.image.astype(np.float64)
    se = math.sqrt(res.variance.astype(np.float64).mean() / img.size * 3)
    assert img.mean() <= 5.0 + 4 * se and img.mean() > 4.9, (img.mean(), se)


def test_choices_compile_only_when_used():
    for text, beck, sep in (("{type: conductor, roughness: 0.2}", 0, 0),
                            ("{type: conductor, roughness: 0.2, distribution: beckmann}", 1, 0),
                            ("{type: conductor, roughness: 0.2, masking: separable}", 0, 1),
                            ("{type: conductor, distribution: beckmann, masking: separable}", 0, 0)):  # mirror
        d = for_world(load_world(_mat(text))).defines()
        assert (d["MCPT_BECKMANN"], d["MCPT_SEPARABLE_MASKING"]) == (beck, sep), text
    assert "diffuse material has no distribution" in _err("{distribution: beckmann}")
    assert "distribution" in _err("{type: conductor, distribution: phong}")


def test_mitsuba_roughconductor_maps_exactly(tmp_path):
    from .test_mitsuba import write_xml

    body = """<shape type="sphere"><bsdf type="roughconductor"><float name="alpha" value="0.07"/>
      <boolean name="sample_visible" value="false"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.2"/></bsdf><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"""
    scene = load_scene(write_xml(tmp_path, body))
    mats = sorted(scene.materials.values(), key=lambda m: m.roughness)
    assert [(m.roughness, m.distribution, m.masking) for m in mats] == [
        (0.07, "beckmann", "separable"), (0.2, "ggx", "separable")]
    with pytest.raises(SceneError, match="expected ggx or beckmann"):
        load_scene(write_xml(tmp_path, '<shape type="sphere"><bsdf type="roughconductor">'
                                       '<string name="distribution" value="phong"/></bsdf></shape>'))
