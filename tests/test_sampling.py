"""Chi-square goodness-of-fit tests of every sampling routine, run on the GLSL code itself
(tests/glsl/probe_sample.frag calls the renderer's functions), after pbrt-v4's bsdfs_test.cpp and
Mitsuba 3's chi2.py (../shared/research/anchors-reliability.md, C3/C4): samples are binned over
the sphere in (cos theta, phi), expected counts come from the GLSL pdf integrated over each cell,
cells expecting < 5 are pooled, and each test must reach the Sidak-corrected alpha."""

import math
import os
import zlib

import numpy as np
import pytest

from mcpt.shading.lights import build_lights
from mcpt.shading.materials import fdr_internal, fresnel_dielectric
from mcpt.shading.metals import METALS

from .test_materials_util import (
    cell_probabilities,
    chi2_test,
    floats,
    probe,
    sidak,
    sphere_grid,
    sphere_histogram,
    uniform_numbers,
)

N = 1 << 19                 # samples per test
SEED_OFFSET = int(os.environ.get("MCPT_TEST_SEED", "0"))  # vary to look at the p-value spread
NT, NP, IRES = 32, 64, 12   # cells in cos theta and phi; sub-cells per axis for the integral
BSDF_CASES = [
    # (name, uniforms)
    ("diffuse", dict(type="diffuse", albedo=(0.5, 0.5, 0.5), wo=(0.0, 0.0, 1.0))),
    ("diffuse-grazing", dict(type="diffuse", albedo=(0.5, 0.5, 0.5), wo=(0.99, 0.0, 0.1411))),
    ("ggx-0.15-normal", dict(type="conductor", albedo=(1, 1, 1), alpha=0.15, wo=(0.0, 0.0, 1.0))),
    ("ggx-0.3-45deg", dict(type="conductor", albedo=(1, 1, 1), alpha=0.3, wo=(0.7071068, 0.0, 0.7071068))),
    ("ggx-0.6-80deg", dict(type="conductor", albedo=(1, 1, 1), alpha=0.6, wo=(0.0, 0.9848078, 0.1736482))),
    ("ggx-1.0-30deg", dict(type="conductor", albedo=(1, 1, 1), alpha=1.0, wo=(0.5, 0.0, 0.8660254))),
    # Conductor Fresnel modes (issue #13): the exact complex Fresnel (gold, copper) and F = 1
    # (flags bits 1-2: mcpt/shading/materials.py FRESNEL), with a lobe scale.
    ("ggx-0.3-45deg-Au", dict(type="conductor", albedo=(1, 1, 1), alpha=0.3, wo=(0.7071068, 0.0, 0.7071068),
                              flags=4, eta=METALS["Au"][0], k=METALS["Au"][1])),
    ("ggx-0.7-75deg-Cu", dict(type="conductor", albedo=(0.9, 0.8, 1.0), alpha=0.7, wo=(0.0, 0.9659258, 0.2588190),
                              flags=4, eta=METALS["Cu"][0], k=METALS["Cu"][1])),
    ("ggx-0.2-60deg-none", dict(type="conductor", albedo=(0.9, 0.9, 0.9), alpha=0.2, wo=(0.8660254, 0.0, 0.5),
                                flags=2)),
    ("plastic-diffuse-lobe", dict(type="plastic", albedo=(0.6, 0.3, 0.2), ior=1.5, fdr_int=fdr_internal(1.5),
                                  wo=(0.6, 0.0, 0.8))),
]
ALPHA = sidak(0.01, len(BSDF_CASES) + 4)


def _uniforms(u):
    base = dict(type="diffuse", albedo=(1, 1, 1), alpha=0.0, ior=1.5, fdr_int=0.0, wo=(0, 0, 1), front=1)
    base.update(u)
    return base


@pytest.mark.parametrize("name,u", BSDF_CASES, ids=[c[0] for c in BSDF_CASES])
def test_bsdf_sampling_matches_its_pdf(gl, name, u):
    p = bsdf_sampling_p(gl, name, _uniforms(u))
    assert p > ALPHA, f"{name}: chi2 p = {p:.3g} < {ALPHA:.3g}"


def bsdf_sampling_p(gl, name: str, u: dict) -> float:
    """The chi-square p-value of the GLSL BSDF's samples (``u``: probe uniforms, _uniforms) against
    its pdf integrated per cell over the sphere (rejected and delta samples one more cell); asserts
    on the way that the pdf integrates to <= 1 and that each sample's pdf and weight are what
    bsdf_eval gives for its direction. Other BSDF tests call it with their own uniforms."""
    rnd = uniform_numbers(N, 2, seed=zlib.crc32(name.encode()) + SEED_OFFSET)
    out = floats(probe(gl, "sample", rnd, **u))
    wi, pdf_ret = out[:, :3].astype(np.float64), out[:, 3].astype(np.float64)
    flags = probe(gl, "weight", rnd, **u)[:, 3]
    valid, delta = (flags & 1) != 0, (flags & 2) != 0
    smooth = valid & ~delta
    assert np.all(np.isfinite(wi[valid])) and np.all(np.isfinite(pdf_ret[valid]))
    # The pdf over the sphere, from the GLSL bsdf_eval, integrated over each cell.
    grid = sphere_grid(NT, NP, IRES)
    ev = floats(probe(gl, "eval", grid.astype(np.float32), **u))
    prob = cell_probabilities(ev[:, 3], NT, NP, IRES)
    # Rejected samples (e.g. GGX reflections below the horizon) and delta-lobe samples are the
    # remaining probability mass, an extra cell.
    p_rest = 1.0 - prob.sum()
    assert p_rest > -2e-3, f"the pdf integrates to {prob.sum():.5f} > 1"
    observed = np.append(sphere_histogram(wi[smooth], NT, NP).ravel(), (~smooth).sum())
    expected = np.append(prob.ravel(), max(p_rest, 0.0)) * N
    p, stat, dof = chi2_test(observed, expected)
    print(f"{name}: chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}")
    # The pdf a sample returns is the pdf bsdf_eval gives for its direction (C4).
    pick = np.nonzero(smooth)[0][:4096]
    ev_s = floats(probe(gl, "eval", wi[pick].astype(np.float32), **u))
    np.testing.assert_allclose(pdf_ret[pick], ev_s[:, 3], rtol=2e-3)
    # And its weight is f|cos| / pdf.
    w = floats(probe(gl, "weight", rnd[pick], **u))[:, :3]
    np.testing.assert_allclose(w, ev_s[:, :3] / ev_s[:, 3:4], rtol=2e-3)
    return p


def test_cosine_pdf_is_the_analytic_one(gl):
    grid = sphere_grid(8, 16, 2)
    ev = floats(probe(gl, "eval", grid.astype(np.float32), **_uniforms(dict(type="diffuse"))))
    np.testing.assert_allclose(ev[:, 3], np.maximum(grid[:, 2], 0) / np.pi, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("ior,front", [(1.5, 1), (1.5, 0), (1.33, 1), (2.4, 0)])
def test_dielectric_reflect_refract_choice_follows_fresnel(gl, ior, front):
    """The reflect / refract choice is a Bernoulli(F) draw: chi-square over the two outcomes for
    each incidence angle, directions by the law of reflection and Snell's law (TIR included)."""
    eta = ior if front else 1.0 / ior
    n = 1 << 15
    ps = []
    for deg in (0.0, 30.0, 41.0, 48.0, 60.0, 85.0):
        t = math.radians(deg)
        wo = (math.sin(t), 0.0, math.cos(t))
        u = _uniforms(dict(type="dielectric", ior=ior, front=front, wo=wo))
        rnd = uniform_numbers(n, 2, seed=int(deg * 10 + ior * 1000 + front))
        flags = probe(gl, "weight", rnd, **u)[:, 3]
        wi = floats(probe(gl, "sample", rnd, **u))[:, :3].astype(np.float64)
        refl = (flags & 4) == 0
        F = float(fresnel_dielectric(math.cos(t), eta))
        if F >= 1.0:
            assert refl.all()
        else:
            p, _, _ = chi2_test([refl.sum(), (~refl).sum()], [F * n, (1 - F) * n], min_expected=0)
            ps.append(p)
        np.testing.assert_allclose(wi[refl], np.broadcast_to([-wo[0], 0.0, wo[2]], wi[refl].shape), atol=1e-6)
        if (~refl).any():
            t_sin = math.sin(t) / eta
            want = [-t_sin, 0.0, -math.sqrt(1 - t_sin**2)]
            np.testing.assert_allclose(wi[~refl], np.broadcast_to(want, wi[~refl].shape), atol=1e-6)
    assert min(ps) > sidak(ALPHA, len(ps))


def test_light_selection_follows_power(gl):
    rng = np.random.default_rng(4)
    areas = rng.uniform(0.1, 2.0, 40)
    emission = np.zeros((40, 3))
    emission[::2] = rng.uniform(0.0, 5.0, (20, 3))  # half the triangles emit
    lights = build_lights(areas, emission)
    rnd = uniform_numbers(N, 1, seed=5)
    out = probe(gl, "light", rnd, tbos={"lights": lights.pack()}, light_count=lights.count)
    idx, pmf = out[:, 0].astype(np.int64), floats(out)[:, 1]
    assert set(np.unique(idx)) <= set(lights.triangles.tolist())
    slot = np.searchsorted(lights.triangles, idx)
    observed = np.bincount(slot, minlength=lights.count)
    p, stat, dof = chi2_test(observed, lights.pmf * N)
    assert p > ALPHA, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"
    np.testing.assert_allclose(pmf, lights.pmf[slot], rtol=1e-6)


def test_triangle_area_sampling_is_uniform(gl):
    """Barycentrics (b1, b2) binned on an n x n grid: cells inside the triangle expect 2/n^2 of
    the samples, cells the diagonal cuts in half expect 1/n^2, the others none."""
    n = 48
    rnd = uniform_numbers(N, 2, seed=6)
    b = floats(probe(gl, "bary", rnd))[:, :2].astype(np.float64)
    assert (b >= 0).all() and (b.sum(axis=1) <= 1 + 1e-6).all()
    h, _, _ = np.histogram2d(b[:, 0], b[:, 1], bins=n, range=[[0, 1], [0, 1]])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    area = np.where(i + j + 2 <= n, 1.0, np.where(i + j + 1 == n, 0.5, 0.0)) * 2.0 / n**2
    p, stat, dof = chi2_test(h, area * N)
    assert p > ALPHA, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"
