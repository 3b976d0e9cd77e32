"""Rough plastic (issue #21; glsl/bsdf_roughplastic.glsl, mcpt/shading/roughplastic.py): the coat's
tables in the smooth limit, chi-square of the real GLSL sampling (table bound as the shader reads
it), energy against the host's formula, what compiles, bad input and the Mitsuba mapping."""

import math
import zlib

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import load_scene
from mcpt.shading import microfacet as MF
from mcpt.shading import roughplastic as RP
from mcpt.shading.materials import FLAG_NONLINEAR, fresnel_dielectric
from mcpt.shapes.world import load_world

from .test_conductor import _err, _mat
from .test_materials_util import (
    PROBE_FEATURES,
    cell_probabilities,
    chi2_test,
    floats,
    probe,
    sidak,
    sphere_grid,
    sphere_histogram,
    uniform_numbers,
)

N = 1 << 19
NT, NP, IRES = 32, 64, 12
CASES = [("ggx-0.1-45", "ggx", 0.1, (0.7071068, 0.0, 0.7071068), (0.6, 0.3, 0.2), False),
         ("ggx-0.4-0", "ggx", 0.4, (0.0, 0.0, 1.0), (0.2, 0.5, 0.9), True),
         ("beckmann-0.2-70", "beckmann", 0.2, (0.0, 0.9396926, 0.3420201), (0.9, 0.9, 0.9), False),
         ("beckmann-0.6-30", "beckmann", 0.6, (0.5, 0.0, 0.8660254), (0.1, 0.1, 0.1), True)]
ALPHA = sidak(0.01, len(CASES))


def _material(dist, alpha, wo, albedo, nonlinear, ior=1.5, masking="separable"):
    """The probe's uniforms and the material buffer holding the table (material 0)."""
    table, fdr = RP.tables(ior, alpha, dist)
    texels = PROBE_FEATURES.material_texels
    buf = np.zeros((texels, 4), np.uint32)
    buf[texels - 16:] = np.asarray(table, np.float32).view(np.uint32).reshape(16, 4)
    w = 1.0 / (1.0 + float(np.mean(albedo)))
    u = dict(type="roughplastic", albedo=albedo, alpha=alpha, ior=ior, fdr_int=fdr, wo=wo, front=1,
             flags=MF.flags(dist, masking) | (FLAG_NONLINEAR if nonlinear else 0), eta=(w, 0.0, 0.0),
             scale=(w, 0.0, 0.0))
    return u, {"materials": buf}, table, fdr


def test_smooth_coat_tables_are_fresnel():
    """alpha 0.001: T(mu) = 1 - F(mu) and Fdr_int = 2 mean(F_inside(mu_k) mu_k) (Mitsuba's mean)."""
    table, fdr = RP.tables(1.5, 0.001, "ggx")
    keep = RP.MU > 0.15
    np.testing.assert_allclose(table[keep], 1.0 - fresnel_dielectric(RP.MU[keep], 1.5), atol=2e-3)
    want = 2.0 * np.mean(fresnel_dielectric(RP.MU, 1 / 1.5) * RP.MU)
    assert abs(fdr - want) < 3e-3, (fdr, want)
    np.testing.assert_allclose(RP.lerp(table, RP.MU[1:]), table[1:], atol=1e-12)  # [0]: mu 1e-6, not 0


@pytest.mark.parametrize("name,dist,alpha,wo,albedo,nonlinear", CASES, ids=[c[0] for c in CASES])
def test_sampling_matches_its_pdf(gl, name, dist, alpha, wo, albedo, nonlinear):
    u, tbos, _, _ = _material(dist, alpha, wo, albedo, nonlinear)
    rnd = uniform_numbers(N, 2, seed=zlib.crc32(name.encode()))
    out = floats(probe(gl, "sample", rnd, tbos=tbos, **u))
    wi, pdf_ret = out[:, :3].astype(np.float64), out[:, 3].astype(np.float64)
    valid = (probe(gl, "weight", rnd, tbos=tbos, **u)[:, 3] & 1) != 0
    grid = sphere_grid(NT, NP, IRES)
    turn = wo[2] > 0.9  # the coat's lobe off the pole (see test_roughdielectric.py)
    if turn:
        grid = np.stack([-grid[:, 2], grid[:, 1], grid[:, 0]], 1)
    ev = floats(probe(gl, "eval", grid.astype(np.float32), tbos=tbos, **u))
    prob = cell_probabilities(ev[:, 3], NT, NP, IRES)
    p_rest = 1.0 - prob.sum()
    assert p_rest > -2e-3, prob.sum()
    seen = np.stack([wi[:, 2], wi[:, 1], -wi[:, 0]], 1) if turn else wi
    observed = np.append(sphere_histogram(seen[valid], NT, NP).ravel(), (~valid).sum())
    p, stat, dof = chi2_test(observed, np.append(prob.ravel(), max(p_rest, 0.0)) * N)
    print(f"{name}: chi2 p = {p:.3g} ({dof} dof)")
    assert p > ALPHA, f"{name}: chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"
    pick = np.nonzero(valid)[0][:4096]
    ev_s = floats(probe(gl, "eval", wi[pick].astype(np.float32), tbos=tbos, **u))
    np.testing.assert_allclose(pdf_ret[pick], ev_s[:, 3], rtol=2e-3)
    w = floats(probe(gl, "weight", rnd[pick], tbos=tbos, **u))[:, :3]
    np.testing.assert_allclose(w, ev_s[:, :3] / ev_s[:, 3:4], rtol=2e-3)


@pytest.mark.parametrize("nonlinear", [False, True])
def test_energy_is_the_coat_plus_the_base(gl, nonlinear):
    """Mean sample weight = E_r(mu) (the coat's reflection, separable masking) + A / (1 - K) T(mu)
    / eta^2 * 2 int T(mu') mu' dmu' (the base), from the host's tables; <= 1 for a white base."""
    mu_q = (np.arange(4000) + 0.5) / 4000
    for dist, alpha in (("ggx", 0.2), ("beckmann", 0.5)):
        for albedo in ((1.0, 1.0, 1.0), (0.5, 0.2, 0.8)):
            for deg in (0.0, 45.0, 75.0):
                t = math.radians(deg)
                wo = (math.sin(t), 0.0, math.cos(t))
                u, tbos, table, fdr = _material(dist, alpha, wo, albedo, nonlinear)
                w = floats(probe(gl, "weight", uniform_numbers(1 << 17, 2, 3), tbos=tbos, **u))[:, :3]
                w = w.astype(np.float64)
                a = np.asarray(albedo)
                k = a * fdr if nonlinear else fdr
                base = 2 * np.mean(RP.lerp(table, mu_q) * mu_q)
                through = a / (1 - k) * RP.lerp(table, math.cos(t)) / 1.5**2 * base
                e = RP._coat(math.cos(t), 1.5, alpha, dist)[0] + through
                se = w.std(0) / math.sqrt(len(w))
                assert np.all(np.abs(w.mean(0) - e) < 4 * se + 3e-3), (dist, alpha, albedo, deg, w.mean(0), e)
                if albedo[0] == 1.0:
                    assert np.all(e <= 1.0 + 1e-3) and np.all(w.mean(0) <= 1.0 + 4 * se)


def test_compiled_only_when_used_and_bad_input(tmp_path):
    f = for_world(load_world(_mat("{type: roughplastic, roughness: 0.2, albedo: [0.5, 0.5, 0.5]}")))
    d = f.defines()
    assert d["MCPT_MAT_ROUGH_PLASTIC"] == d["MCPT_MICROFACET"] == 1 and f.material_texels == 20
    assert for_world(load_world(_mat("{type: plastic}"))).defines()["MCPT_MAT_ROUGH_PLASTIC"] == 0
    assert "needs roughness (alpha) in [0.001, 1], got 0" in _err("{type: roughplastic}")
    assert "ior 1 is no interface" in _err("{type: roughplastic, roughness: 0.1, ior: 1}")
    assert "diffuse material has no nonlinear" in _err("{nonlinear: true}")
    from .test_mitsuba import write_xml

    body = """<shape type="sphere"><bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.6"/>
      <boolean name="nonlinear" value="true"/><string name="distribution" value="ggx"/></bsdf></shape>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"""
    m = [m for m in load_scene(write_xml(tmp_path, body)).materials.values() if m.type == "roughplastic"][0]
    assert (m.roughness, m.distribution, m.masking, m.nonlinear, m.albedo) == (
        0.1, "ggx", "separable", True, (0.2, 0.4, 0.6))
    assert abs(m.ior - 1.49 / 1.000277) < 1e-9
    # Refused before issue #22; mapped now (tests/test_specular_weights.py).
    m = load_scene(write_xml(tmp_path, '<shape type="sphere"><bsdf type="roughplastic">'
                                       '<rgb name="specular_reflectance" value="0.5"/></bsdf></shape>'))
    assert [x.specular_reflectance for x in m.materials.values()] == [(0.5, 0.5, 0.5)]


@pytest.mark.parametrize("dist", MF.DISTRIBUTIONS)
def test_reciprocity(gl, dist):
    """f(wo, wi) = f(wi, wo): coat and base alike (T(cos_o) T(cos_i) is symmetric)."""
    rng = np.random.default_rng(11)
    wi = rng.normal(size=(48, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = (0.6, 0.0, 0.8)
    u, tbos, _, _ = _material(dist, 0.3, wo, (0.4, 0.7, 0.2), True)
    fwd = floats(probe(gl, "eval", wi.astype(np.float32), tbos=tbos, **u))[:, :3] / wi[:, 2:3]
    back = np.array([floats(probe(gl, "eval", np.float32([wo]), tbos=tbos, **{**u, "wo": tuple(w)}))[0, :3]
                     for w in wi]) / wo[2]
    np.testing.assert_allclose(fwd, back, rtol=2e-3)


def test_smooth_plastic_linear_mode(gl):
    """Smooth plastic (glsl/bsdf_plastic.glsl) in both of Mitsuba's modes: the base divided by
    1 - Fdr_int (nonlinear false) or 1 - A Fdr_int (true); the YAML default is true for plastic."""
    from mcpt.shading.materials import fdr_internal

    fdr = fdr_internal(1.5)
    u = dict(type="plastic", albedo=(0.2, 0.5, 0.9), ior=1.5, fdr_int=fdr, wo=(0.6, 0.0, 0.8))
    wi = np.float32([[-0.3, 0.2, 0.9327379], [0.1, -0.5, 0.8602325]])
    lin = floats(probe(gl, "eval", wi, **u))[:, :3].astype(np.float64)
    non = floats(probe(gl, "eval", wi, **{**u, "flags": FLAG_NONLINEAR}))[:, :3].astype(np.float64)
    a = np.asarray(u["albedo"])
    np.testing.assert_allclose(lin / non, np.broadcast_to((1 - a * fdr) / (1 - fdr), lin.shape), rtol=1e-5)
    assert _mat("{type: plastic}").materials["m"].nonlinear_mode is True
    assert _mat("{type: plastic, nonlinear: false}").materials["m"].nonlinear_mode is False
    assert _mat("{type: roughplastic, roughness: 0.1}").materials["m"].nonlinear_mode is False
