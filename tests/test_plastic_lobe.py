"""Smooth plastic's lobe choice (issue #21, "Variance"; glsl/bsdf_plastic.glsl, host twin
mcpt.shading.materials.plastic_spec_prob): the coat is sampled with Mitsuba 3's probability
Fo w / (Fo w + (1 - Fo)(1 - w)), w = 1 / (1 + mean A), its sample weighs Fo / ps, and the diffuse
lobe still samples its pdf (chi-square on the real GLSL, as tests/test_sampling.py). Also the
statistics of bench/plastic_variance.py, which measured it, on synthetic runs."""

import math

import numpy as np
import pytest

from mcpt.shading.materials import fdr_internal, fresnel_dielectric, plastic_spec_prob

from . import test_sampling as sampling
from .test_materials_util import floats, probe, uniform_numbers

N = 1 << 16
CASES = [  # (albedo, ior, cos_o): the material preview's red (Mitsuba's matpreview, ior 1.9), others
    ((0.940, 0.271, 0.361), 1.9, 1.0),
    ((0.940, 0.271, 0.361), 1.9, 0.3),
    ((0.6, 0.3, 0.2), 1.5, 0.8),
    ((0.05, 0.05, 0.05), 1.5, 0.95),
    ((1.0, 1.0, 1.0), 1.33, 0.1),
]


def _u(albedo, ior, cos_o, flags=0):
    return dict(type="plastic", albedo=albedo, alpha=0.0, ior=ior, fdr_int=fdr_internal(ior),
                wo=(math.sqrt(1.0 - cos_o * cos_o), 0.0, cos_o), front=1, flags=flags)


def test_host_twin_is_mitsubas_rule():
    # Mitsuba 3's numbers for its matpreview plastic at normal incidence: Fo = (0.9 / 2.9)^2,
    # d_mean = 0.524, specular_sampling_weight = 1 / 1.524.
    fo = (0.9 / 2.9) ** 2
    w = 1.0 / (1.0 + (0.940 + 0.271 + 0.361) / 3.0)
    want = fo * w / (fo * w + (1.0 - fo) * (1.0 - w))
    assert plastic_spec_prob((0.940, 0.271, 0.361), 1.0, 1.9) == pytest.approx(want, rel=1e-12)
    assert want == pytest.approx(0.1690, abs=1e-4)  # mcpt's old max3 rule gave 0.102 here
    assert plastic_spec_prob((0.0, 0.0, 0.0), 0.5, 1.5) == 1.0  # a black base: only the coat


@pytest.mark.parametrize("albedo,ior,cos_o", CASES)
def test_coat_is_picked_with_mitsubas_probability_and_weighs_fo_over_it(gl, albedo, ior, cos_o):
    ps = float(plastic_spec_prob(albedo, cos_o, ior))
    fo = float(fresnel_dielectric(cos_o, ior))
    out = probe(gl, "weight", uniform_numbers(N, 2, seed=int(cos_o * 1000) + int(ior * 10)), **_u(albedo, ior, cos_o))
    flags, w = out[:, 3], floats(out)[:, :3].astype(np.float64)
    assert ((flags & 1) != 0).all()
    delta = (flags & 2) != 0
    # u.x < ps picks the coat: a binomial count, within 5 sigma of N ps.
    assert abs(delta.sum() - N * ps) < 5 * math.sqrt(N * ps * (1 - ps)) + 1, (delta.mean(), ps)
    # Every coat sample weighs exactly Fo / ps (grey): the old max3 rule gives other weights.
    np.testing.assert_allclose(w[delta], fo / ps, rtol=2e-5)
    # The mixture stays unbiased: E[weight] is the directional albedo, here Fo plus the diffuse
    # lobe's share (checked loosely: the diffuse part is a Monte Carlo mean).
    assert np.all(w.mean(axis=0) >= fo * (1 - 1e-3))


@pytest.mark.parametrize("flags", [0, 64], ids=["linear", "nonlinear"])
@pytest.mark.parametrize("albedo,ior,cos_o", CASES[1:3])
def test_diffuse_lobe_chi2_with_the_new_choice(gl, albedo, ior, cos_o, flags):
    """tests/test_sampling.py's chi-square (GLSL pdf integrated per cell, the delta samples one more
    cell, pdf and weight consistent per sample) on the plastic at other angles, albedos and modes."""
    name = f"plastic-{albedo[0]}-{ior}-{cos_o}-{flags}"
    p = sampling.bsdf_sampling_p(gl, name, sampling._uniforms(_u(albedo, ior, cos_o, flags)))
    assert p > sampling.ALPHA, f"{name}: chi2 p = {p:.3g} < {sampling.ALPHA:.3g}"


# ----------------------------------------------------------------------------------------------
# bench/plastic_variance.py: the statistics on synthetic runs (no renderer)


def test_bench_variance_ratio_trim_and_firefly_share():
    from mcpt.bench import plastic_variance as pv

    rng = np.random.default_rng(3)
    ref = np.full((20, 10, 3), 0.5)
    mts = ref + rng.normal(0.0, 0.05, (16, 20, 10, 3))
    mc = ref + rng.normal(0.0, 0.1, (16, 20, 10, 3))   # 4x the variance everywhere
    r = pv.compare(mc, mts)
    assert r["ratio"] == pytest.approx(4.0, rel=0.15) and r["ratio_trim"] == pytest.approx(4.0, rel=0.15)
    assert 0.0 < r["ratio_se"] < 1.0
    mc[5, 3, 4] += 50.0  # one firefly in one run: the overall ratio jumps, the trimmed one not
    f = pv.compare(mc, mts)
    assert f["ratio"] > 10 * r["ratio"] and f["ratio_trim"] == pytest.approx(r["ratio_trim"], rel=0.05)
    assert f["top1_share_mcpt"] > 0.9 and r["top1_share_mcpt"] < 0.1


def test_bench_renders_each_mitsuba_run_at_the_full_spp(monkeypatch, tmp_path):
    """One Mitsuba process per run at ``spp``: ``run_mitsuba(spp, runs=R)`` would split spp over
    the R runs, and its spread would be that of spp / R images (an 8x error at R = 8)."""
    from mcpt.bench import differential
    from mcpt.bench import plastic_variance as pv

    calls = []

    def fake(scene, spp, seed, defines, runs, tmp, resolution=None):
        calls.append((spp, seed, runs, resolution))
        return {"mean": np.full((2, 2, 3), float(seed))}

    monkeypatch.setattr(differential, "run_mitsuba", fake)
    images = pv.mitsuba_runs(tmp_path / "s.xml", 64, 3, "4x4", tmp_path)
    assert calls == [(64, 0, 1, "4x4"), (64, 1, 1, "4x4"), (64, 2, 1, "4x4")]
    assert images.shape == (3, 2, 2, 3)
