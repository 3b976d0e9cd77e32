"""Participating media (issue #25): the Henyey-Greenstein phase function's sampling against its pdf
(chi-square on the real GLSL), free-flight sampling's weights, and closed forms through the whole
path tracer: transmittance to an emitter across a purely absorbing fog, and the furnace, whose
radiance a non-absorbing medium leaves unchanged (Le / (1 - rho)) whatever its density and g."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world, loop_limit_for
from mcpt.scene import SceneError, parse_scene
from mcpt.shading.medium import MediumError
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .probes import run_test_probe
from .test_materials_util import (
    PROBE_FEATURES,
    cell_probabilities,
    chi2_test,
    floats,
    renderer,
    sidak,
    sphere_grid,
    sphere_histogram,
    uniform_numbers,
)

N = 1 << 19
NT, NP, IRES = 32, 64, 12
G_CASES = [-0.7, 0.0, 0.5, 0.9]
ALPHA = sidak(0.01, len(G_CASES))
MEDIUM_FEATURES = PROBE_FEATURES  # the uber-shader's defines: MCPT_MEDIUM on


def probe(gl, mode: int, items: np.ndarray, **uniforms) -> np.ndarray:
    buf = np.zeros((len(items), 4), np.float32)
    buf[:, : items.shape[1]] = items
    return floats(run_test_probe(
        gl, "probe_medium.frag", buf.view(np.uint32), len(items), preamble=MEDIUM_FEATURES.preamble(),
        key=("probe_medium", MEDIUM_FEATURES.key), uniforms={"u_mode": mode, **uniforms}, width=1024))


@pytest.mark.parametrize("g", G_CASES)
def test_hg_sampling_matches_its_pdf(gl, g):
    """Directions from hg_sample binned over the sphere about a tilted incoming direction d,
    against hg_eval integrated over each cell; the pdf it returns is hg_eval's; the pdf
    integrates to 1."""
    d = np.array([0.3, -0.5, 0.8124038])
    d /= np.linalg.norm(d)
    u = {"u_d": tuple(map(float, d)), "u_g": float(g)}
    out = probe(gl, 0, uniform_numbers(N, 2, 1000 + int(10 * g)), **u).astype(np.float64)
    wi, pdf = out[:, :3], out[:, 3]
    assert np.allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-5)
    grid = sphere_grid(NT, NP, IRES)
    ev = probe(gl, 1, (grid @ d)[:, None].astype(np.float32), **u)[:, 0]
    expected = cell_probabilities(ev, NT, NP, IRES)
    assert abs(expected.sum() - 1.0) < 2e-3, f"g = {g}: the pdf integrates to {expected.sum():.5f}"
    p, stat, dof = chi2_test(sphere_histogram(wi, NT, NP), expected * N)
    assert p > ALPHA, f"g = {g}: chi2 = {stat:.1f} for {dof} dof, p = {p:.3g} < {ALPHA:.3g}"
    analytic = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * (wi @ d)) ** 1.5)
    assert np.allclose(pdf, analytic, rtol=2e-3)


def test_free_flight_weights_average_to_transmittance(gl):
    """Free-flight sampling over a segment of length 1.25 of a chromatic medium (sigma_t 0.4, 1, 2.5,
    sigma_s = sigma_t / 2): the pass weights average to Tr(1.25) per channel and the scattering
    weights' distances follow sigma_s Tr(t) (their mean weight over [0, 1.25] = the integral)."""
    st = np.array([0.4, 1.0, 2.5])
    ss = st / 2
    n, t_hit = 1 << 20, 1.25
    u = uniform_numbers(n, 1, 77)[:, 0]
    items = np.stack([u, np.full(n, t_hit, np.float32)], axis=1)
    coefficients = {"u_medium_sigma_t": tuple(map(float, st)), "u_medium_sigma_s": tuple(map(float, ss))}
    out = probe(gl, 2, items, **coefficients).astype(np.float64)
    t, w = out[:, 0], out[:, 1:]
    passed = t >= t_hit
    tr = np.exp(-st * t_hit)
    assert np.allclose(w[passed].sum(0) / n, tr, rtol=0.01), (w[passed].sum(0) / n, tr)
    # E[scatter weight] = integral of sigma_s Tr(t) dt over [0, t_hit] = sigma_s / sigma_t (1 - Tr)
    assert np.allclose(w[~passed].sum(0) / n, ss / st * (1 - tr), rtol=0.01)
    near = ~passed & (t < 0.5)  # and of their distances: the first moment over [0, 0.5]
    first = ss * (1 - np.exp(-st * 0.5) * (1 + st * 0.5)) / st**2
    assert np.allclose((w[near] * t[near, None]).sum(0) / n, first, rtol=0.02)


def _render(gl, text: str, spp: int, seed: int, **flags):
    world = load_world(parse_scene(text, ROOT / "scenes" / "inline.yaml"))
    feats = for_world(world, variance=True, loop_limit=loop_limit_for(gl.renderer), **flags)
    r = renderer(gl, world, feats)
    try:
        return draw(r, spp, seed), feats
    finally:
        r.release()


def furnace(medium: str, albedo: float = 0.8, bounces: int = 1000) -> str:
    return f"""
camera: {{position: [0, 0, 0], look_at: [0, 0, -1], up: [0, 1, 0], vfov_deg: 60, resolution: [16, 16]}}
render: {{bounces: {bounces}}}
materials:
  furnace: {{albedo: [{albedo}, {albedo}, {albedo}], emission: [1.0, 1.0, 1.0]}}
meshes:
  - {{file: furnace/sphere_inward.obj, material: furnace}}
medium: {medium}
"""


@pytest.mark.parametrize("medium,sampling", [
    ("{sigma_a: 0, sigma_s: 1.0}", "mis"),
    ("{sigma_a: 0, sigma_s: [1.0, 1.5, 2.0], g: -0.7}", "mis"),
    ("{albedo: 1, density: 3.0, g: 0.9}", "mis"),
    ("{sigma_a: 0, sigma_s: 1.0, g: 0.5}", "nee"),
    ("{sigma_a: 0, sigma_s: 1.0, g: 0.5}", "bsdf"),
])
def test_non_absorbing_fog_leaves_the_furnace_at_le_over_1_minus_rho(gl, medium, sampling):
    """Inside a closed emitter of radiance 1 and albedo 0.8, radiance is 5 everywhere; a medium
    that only scatters (any density, any g, chromatic) keeps it so: every estimator, within noise."""
    res, feats = _render(gl, furnace(medium), 64, 5, sampling=sampling)
    assert feats.defines()["MCPT_MEDIUM"] == 1
    # 1000 bounces on llvmpipe: paths are continued across draws (glsl/path_state.glsl), medium
    # vertices included; none is dropped.
    assert feats.continues or feats.loop_limit == 0
    m = res.image.reshape(-1, 3).mean(0)
    se = np.sqrt(res.variance.reshape(-1, 3).mean(0) / (16 * 16))
    assert res.dropped_samples == 0
    assert np.all(np.abs(m - 5.0) < 4 * se + 0.01), (m, se)


def test_absorbing_fog_dims_an_emitter_by_its_transmittance(gl):
    """A camera ray across a purely absorbing fog (sigma_a per channel) to a black emitter of
    radiance 1 at distance 2 sees exp(-2 sigma_a); nothing scatters, so nothing else arrives."""
    text = """
camera: {position: [0, 0, 2], look_at: [0, 0, 0], vfov_deg: 10, resolution: [8, 8]}
render: {bounces: 4}
materials:
  lamp: {albedo: [0, 0, 0], emission: [1, 1, 1]}
meshes:
  - {shape: rectangle, material: lamp, transform: {scale: 5}}
medium: {sigma_a: [0.1, 0.5, 1.0], sigma_s: 0}
"""
    res, _ = _render(gl, text, 256, 9)
    m = res.image.reshape(-1, 3).mean(0)
    expected = np.exp(-2 * np.array([0.1, 0.5, 1.0]))
    se = np.sqrt(res.variance.reshape(-1, 3).mean(0) / 64)
    assert np.all(np.abs(m - expected) < 4 * se + 1e-3), (m, expected, se)


@pytest.mark.parametrize("medium,message", [
    ("{sigma_a: -1, sigma_s: 1}", "medium.sigma_a.0: Input should be greater than or equal to 0"),
    ("{sigma_a: 0, sigma_s: 1, g: 1.0}", "medium.g: Input should be less than 1"),
    ("{sigma_a: 0, sigma_s: 1, g: -1}", "medium.g: Input should be greater than -1"),
    ("{sigma_a: .inf, sigma_s: 1}", "medium.sigma_a: Input should be a finite number"),
    ("{albedo: 0.5}", "medium.density: albedo and density go together"),
    ("{albedo: 1.5, density: 1}", "medium.albedo.0: Input should be less than or equal to 1"),
    ("{sigma_a: 0, sigma_s: 0}", "medium.sigma_s: the medium is empty"),
    ("{sigma_a: 1, density: 2}", "medium.sigma_s: give sigma_a and sigma_s, or albedo and density"),
    ("{albedo: 0.5, density: 1e9}", "medium.density: sigma_t 1e+09 per world unit"),
])
def test_bad_media_are_one_located_line(medium, message):
    with pytest.raises(SceneError) as exc:
        parse_scene(furnace(medium).replace("1e9", "1000000000.0"), ROOT / "scenes" / "inline.yaml")
    text = str(exc.value)
    assert "\n" not in text and "inline.yaml:8: " + message in text, text


def glass_scene(inside: str, bounces: int = 8, env: str = "[1, 1, 1]") -> str:
    return f"""
camera: {{position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 30, resolution: [24, 24]}}
render: {{bounces: {bounces}}}
materials:
  glass: {{type: dielectric, {inside}}}
  floor: {{albedo: [0.6, 0.6, 0.6]}}
meshes:
  - {{file: models/icosphere.obj, material: glass}}
  - {{shape: rectangle, material: floor, transform: {{scale: 3, rotate_deg: [-90, 0, 0], translate: [0, -1, 0]}}}}
environment: {{radiance: {env}}}
"""


def test_beer_lambert_is_the_non_scattering_interior_medium(gl):
    """Issue #25: an absorbing glass sphere (absorption: color, distance) and the same glass with an
    interior medium of sigma_a = -ln(color) / distance, sigma_s = 0 render the same pixels (one
    seed): the medium code does the absorbing, the Beer-Lambert code is compiled out."""
    color, distance = np.array([0.5, 0.7, 0.9]), 1.0
    sigma_a = [float(x) for x in -np.log(color) / distance]
    old, f_old = _render(gl, glass_scene("ior: 1.5, absorption: {color: [0.5, 0.7, 0.9], distance: 1.0}"), 16, 3)
    new, f_new = _render(gl, glass_scene(f"ior: 1.5, interior: {{sigma_a: {sigma_a}, sigma_s: 0}}"), 16, 3)
    assert f_old.defines()["MCPT_ABSORPTION"] == 1 and f_old.defines()["MCPT_MEDIUM"] == 0
    assert f_new.defines()["MCPT_ABSORPTION"] == 0 and f_new.defines()["MCPT_MEDIUM_INTERIOR"] == 1
    clear, _ = _render(gl, glass_scene("ior: 1.5"), 16, 3)
    assert np.abs(old.image - clear.image).max() > 0.1  # the absorption shows
    assert np.allclose(old.image, new.image, rtol=1e-5, atol=1e-6)


def test_non_absorbing_sphere_under_a_constant_sky_is_invisible(gl):
    """A sphere of scattering medium (albedo 1, dense, forward-scattering) behind an index-matched
    boundary (ior 1) under a constant sky of radiance L: radiance is L everywhere (the uniform
    field solves the transport equation without absorption), so every pixel on it is L."""
    text = glass_scene("ior: 1.0, interior: {albedo: 1, density: 4, g: 0.6}", 1000, "[1, 2, 3]")
    text = text.replace("  - {shape: rectangle", "#")
    res, feats = _render(gl, text, 64, 4)
    assert feats.defines()["MCPT_MEDIUM_INTERIOR"] == 1 and res.dropped_samples == 0
    m = res.image.reshape(-1, 3).mean(0)
    se = np.sqrt(res.variance.reshape(-1, 3).mean(0) / res.image[..., 0].size)
    assert np.all(np.abs(m - [1, 2, 3]) < 4 * se + 0.01), (m, se)


def test_interior_medium_on_an_open_mesh_is_one_located_line(gl):
    text = glass_scene("ior: 1.5, interior: {sigma_a: 1, sigma_s: 1}").replace(
        "file: models/icosphere.obj, material: glass", "shape: rectangle, material: glass")
    with pytest.raises(MediumError) as exc:
        for_world(load_world(parse_scene(text, ROOT / "scenes" / "inline.yaml")))
    assert str(exc.value).startswith(f"{ROOT / 'scenes' / 'inline.yaml'}:5: materials.glass.interior: the meshes "
                                     "of material 'glass' are open (4 edges with one triangle)"), str(exc.value)


def test_interior_is_for_dielectrics_without_absorption():
    for inside, message in [("type: diffuse, interior: {sigma_a: 1, sigma_s: 1}", "a diffuse material has no interior"),
                            ("type: dielectric, absorption: {color: [0.5, 0.5, 0.5], distance: 1}, "
                             "interior: {sigma_a: 1, sigma_s: 1}", "give absorption or interior")]:
        with pytest.raises(SceneError) as exc:
            parse_scene(glass_scene("ior: 1.5").replace("type: dielectric, ior: 1.5", inside),
                        ROOT / "scenes" / "inline.yaml")
        assert message in str(exc.value) and "materials.glass" in str(exc.value), str(exc.value)


def test_clear_glass_in_fog_holds_vacuum(gl):
    """Inside a glass sphere without an interior, in a scene-wide fog, there is no fog (Mitsuba 3:
    a shape without an interior medium holds none): the sphere renders as in a fog whose glass
    holds an interior of (almost) nothing, and unlike one that holds the fog itself (what it
    rendered before the clear glass was told apart)."""
    fog = "medium: {albedo: 0.8, density: 0.5}\nlights: [{type: point, position: [1, 2, 2], intensity: [9, 9, 9]}]\n"
    clear, _ = _render(gl, glass_scene("ior: 1.5") + fog, 64, 6)
    empty, _ = _render(gl, glass_scene("ior: 1.5, interior: {sigma_a: 0, sigma_s: 1e-9}") + fog, 64, 6)
    foggy, _ = _render(gl, glass_scene("ior: 1.5, interior: {albedo: 0.8, density: 0.5}") + fog, 64, 6)
    sphere = (slice(6, 18), slice(6, 18))
    a, c = clear.image[sphere].mean(), foggy.image[sphere].mean()
    # One seed, the same random numbers: a medium of nothing changes no pixel, the fog does.
    assert np.allclose(clear.image, empty.image, rtol=1e-3, atol=1e-5)
    assert abs(a - c) > 0.02 * a, (a, c)


def test_a_medium_vertex_writes_its_albedo_and_depth_aovs():
    """AOVs (glsl/aov.glsl): the first non-specular vertex may be a medium vertex, which writes the
    single-scattering albedo sigma_s / sigma_t, normal 0 (the host renormalises the mean normal)
    and (camera ray) its distance. In the fog
    furnace (camera at the centre of a sphere of radius ~1, gray sigma_t 1) a camera ray scatters
    before the wall with probability 1 - exp(-1): mean albedo (1 - e^-1) alb + e^-1 0.8, mean depth
    E[min(t, 1)] = 1 - e^-1."""
    from mcpt.prepare import prepare

    alb = np.array([0.5, 0.7, 0.9])
    sc = parse_scene(furnace("{albedo: [0.5, 0.7, 0.9], density: 1.0}", bounces=4), ROOT / "scenes" / "inline.yaml")
    p = prepare(sc, aovs=("albedo", "normal", "depth"))
    try:
        total = sum(sums for _, sums in p.renderer.passes(3, 0, 256))
        res = p.renderer.result(total, 256, 3, 0.0, 0.0)
    finally:
        p.renderer.release()
    scatter = 1 - math.exp(-1)
    albedo = res.aovs["albedo"].reshape(-1, 3).mean(0)
    assert np.allclose(albedo, scatter * alb + (1 - scatter) * 0.8, atol=0.01), albedo
    depth = float(res.aovs["depth"].mean())
    assert abs(depth - scatter) < 0.01, depth


def test_fog_passes_split_anywhere_add_the_same_numbers():
    """Resume and the farm add read-backs of pass ranges (mcpt/gpu/render.py passes): in a fog with
    a spot light (free flight, equiangular, continuation of 100-bounce paths), passes 0-63 in one
    call and as 0-23 + 24-63 give the same read-backs, bit for bit."""
    from mcpt.prepare import prepare

    sc = parse_scene(furnace("{albedo: [0.9, 0.8, 0.7], density: 1.0, g: 0.5}", bounces=100).replace(
        "medium:", "lights: [{type: spot, position: [0, 0.5, 0], look_at: [0, 0, -1], intensity: [3, 3, 3]}]\n"
        "medium:"), ROOT / "scenes" / "inline.yaml")
    p = prepare(sc)
    try:
        assert p.renderer.features.defines()["MCPT_MEDIUM_EQUIANGULAR"] == 1
        one = [sums.copy() for _, sums in p.renderer.passes(11, 0, 64, chunk=8)]
        split = [sums.copy() for _, sums in p.renderer.passes(11, 0, 24, chunk=8)]
        split += [sums.copy() for _, sums in p.renderer.passes(11, 24, 64, chunk=8)]
    finally:
        p.renderer.release()
    assert len(one) == len(split) == 8
    for a, b in zip(one, split):
        np.testing.assert_array_equal(a, b)
    assert float(sum(s[0, ..., :3].sum() for s in one)) > 0


def test_a_thin_lens_and_a_medium_read_their_own_numbers(gl):
    """A thin lens (2 numbers after the bounces') and the medium's free-flight block do not
    overlap, and the fog furnace stays at 5 seen through the lens."""
    from mcpt.shading.sampler import dims_for

    text = furnace("{sigma_a: 0, sigma_s: 1.0, g: 0.5}", bounces=200).replace(
        "resolution: [16, 16]}", "resolution: [16, 16], lens: {focus_distance: 0.8, aperture_radius: 0.05}}")
    res, feats = _render(gl, text, 64, 5)
    d = feats.defines()
    assert d["MCPT_THIN_LENS"] == 1 and d["MCPT_DIM_MEDIUM"] == dims_for(200, True) > dims_for(200)
    assert feats.random_dims == dims_for(200, True) + 200
    m = res.image.reshape(-1, 3).mean(0)
    se = np.sqrt(res.variance.reshape(-1, 3).mean(0) / (16 * 16))
    assert np.all(np.abs(m - 5.0) < 4 * se + 0.01), (m, se)


def test_the_uber_shader_renders_media_too(gl):
    """--features all compiles every medium path (scene-wide, interior, equiangular) for any scene:
    with a scene's medium it gives the fog furnace's 5, and without one (zero coefficients) the
    clear furnace's 5 as well."""
    for medium in ("{sigma_a: 0, sigma_s: 1.0, g: 0.5}", None):
        text = furnace(medium or "{sigma_a: 0, sigma_s: 1.0}", bounces=1000)
        if medium is None:
            text = text.split("medium:")[0]
        world = load_world(parse_scene(text, ROOT / "scenes" / "inline.yaml"))
        f = for_world(world, variance=True, loop_limit=loop_limit_for(gl.renderer)).everything()
        d = f.defines()
        assert d["MCPT_MEDIUM"] == d["MCPT_MEDIUM_INTERIOR"] == d["MCPT_MEDIUM_EQUIANGULAR"] == 1
        r = renderer(gl, world, f)
        try:
            res = draw(r, 32, 2)
        finally:
            r.release()
        m = res.image.reshape(-1, 3).mean(0)
        se = np.sqrt(res.variance.reshape(-1, 3).mean(0) / (16 * 16))
        assert res.dropped_samples == 0 and np.all(np.abs(m - 5.0) < 4 * se + 0.01), (medium, m, se)
