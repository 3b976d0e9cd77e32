"""Pixel filters on the real GLSL (tests/glsl/probe_camera.frag): chi-square of the offsets against
Mitsuba's filter densities (interior and film-edge pixels), the inverse CDF against a float64
bisection, the box filter compiled out, a sharp edge rendered as the filter's CDF, and the YAML /
Mitsuba XML mapping of the filter (issue #22)."""

import math
import zlib

import numpy as np
import pytest

from mcpt.gpu.features import Features
from mcpt.scene.model import Camera
from mcpt.shading import pixel_filter as pf
from mcpt.shading.camera import camera_uniforms, camera_uses

from .camera_probe import RES, camera, run_camera_probe
from .test_materials_util import chi2_test, sidak, uniform_numbers

N = 1 << 19
BINS = 32
FILTER_CASES = [  # (name, camera.filter, pixel)
    ("gaussian-default", {"type": "gaussian"}, (8, 8)),
    ("gaussian-0.3", {"type": "gaussian", "stddev": 0.3}, (5, 10)),
    ("tent-default", {"type": "tent"}, (8, 8)),
    ("tent-2.5", {"type": "tent", "radius": 2.5}, (7, 9)),
    ("gaussian-corner", {"type": "gaussian"}, (0, 1)),   # filter cut by the film's edges
    ("tent-edge", {"type": "tent", "radius": 2.5}, (15, 8)),
]
ALPHA = sidak(0.01, len(FILTER_CASES))


def bin_probabilities(cam: Camera, edges: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Probability of each bin under Mitsuba's filter (the exact formula, not the table) cut to
    [lo, hi], by fine midpoint quadrature."""
    f = cam.filter
    fine = np.linspace(edges[0], edges[-1], (len(edges) - 1) * 400 + 1)
    mid = 0.5 * (fine[1:] + fine[:-1])
    w = pf.evaluate(f.type, mid, f.std, f.tent_radius) * ((mid >= lo) & (mid <= hi))
    per_bin = w.reshape(len(edges) - 1, 400).sum(axis=1)
    return per_bin / per_bin.sum()


@pytest.mark.parametrize("name,spec,pixel", FILTER_CASES, ids=[c[0] for c in FILTER_CASES])
def test_filter_offsets_follow_the_filter(gl, name, spec, pixel):
    cam = camera(filter=spec)
    u = uniform_numbers(N, 2, seed=zlib.crc32(name.encode()))
    jit = run_camera_probe(gl, cam, 0, u, np.tile(pixel, (N, 1)))
    off = jit.astype(np.float64)[:, :2] - 0.5
    r = cam.filter.support
    assert np.all(np.abs(off) <= r * (1 + 1e-6))
    lo = [-(c + 0.5) for c in pixel]
    hi = [RES - c - 0.5 for c in pixel]
    # every sample on the film
    assert np.all(off >= np.array(lo) - 1e-5) and np.all(off <= np.array(hi) + 1e-5)
    edges = np.linspace(-r, r, BINS + 1)
    px, py = (bin_probabilities(cam, edges, lo[a], hi[a]) for a in (0, 1))
    observed, _, _ = np.histogram2d(off[:, 0], off[:, 1], bins=(edges, edges))
    p, stat, dof = chi2_test(observed, np.outer(px, py) * N)
    print(f"{name}: chi2 p = {p:.3g} ({stat:.1f} / {dof} dof)")
    assert p > ALPHA, f"{name}: chi2 {stat:.1f} / {dof} dof, p = {p:.3g}"
    # the shader's inverse CDF is the exact one (float64 bisection): in CDF terms to 1e-6 where
    # the CDF is above 1e-3 (Newton's method for the Gaussian, a closed form for the tent)
    k = 4096
    ref = pf.sample_reference(cam.filter.type, u[:k, 0].astype(np.float64), lo[0], hi[0],
                              cam.filter.std, cam.filter.tent_radius)
    c_got = pf.cdf(cam.filter.type, off[:k, 0], cam.filter.std, cam.filter.tent_radius)
    c_ref = pf.cdf(cam.filter.type, ref, cam.filter.std, cam.filter.tent_radius)
    bulk = (c_ref > 1e-3) & (c_ref < 1 - 1e-3)
    err = np.abs(c_got - c_ref)
    assert err[bulk].max() < 1e-6 and err.max() < 2e-5, (err[bulk].max(), err.max())


def test_filter_offsets_are_monotone_in_u(gl):
    """Inverse CDF: u -> offset increasing, so the sampler's stratification survives."""
    cam = camera(filter={"type": "gaussian"})
    u = np.stack([np.linspace(0, 1 - 2**-24, 5000), np.full(5000, 0.5)], axis=1).astype(np.float32)
    off = run_camera_probe(gl, cam, 0, u, np.tile((8, 8), (5000, 1)))[:, 0] - 0.5
    assert np.all(np.diff(off) >= 0) and off[0] < -1.9 and off[-1] > 1.9


def test_box_filter_compiles_nothing_and_jitters_uniformly(gl):
    cam = camera()
    assert camera_uses(cam)["pixel_filter"] == 0
    assert Features.of(bounces=1, **camera_uses(cam)).defines()["MCPT_FILTER"] == 0
    assert "u_filter_radius" not in camera_uniforms(cam)
    from .rays import primary_rays
    u = uniform_numbers(64, 2, seed=5)
    pix = np.stack([np.arange(64) % RES, np.arange(64) // RES % RES], axis=1)
    d = run_camera_probe(gl, cam, 1, u, pix)[:, :3]
    for k in range(64):
        _, ref = primary_rays(cam.position, cam.look_at, cam.up, cam.vfov_deg, RES, RES,
                              jitter=tuple(u[k].astype(np.float64)))
        assert np.allclose(d[k], ref[pix[k, 1], pix[k, 0]], atol=2e-6)


@pytest.mark.parametrize("spec,error", [
    ({"type": "gaussian", "radius": 1.0}, "radius is for the tent filter"),
    ({"type": "tent", "stddev": 1.0}, "stddev is for the gaussian filter"),
    ({"type": "gaussian", "stddev": 5.0}, "exceeds 16 px"),
    ({"type": "mitchell"}, "Input should be"),
    ({"type": "tent", "radius": 0.0}, "greater than 0"),
])
def test_bad_filter_is_one_located_line(tmp_path, spec, error):
    from mcpt.scene import SceneError, load_scene
    text = ("camera:\n  position: [0, 0, 1]\n  look_at: [0, 0, 0]\n  vfov_deg: 40\n  resolution: [8, 8]\n"
            f"  filter: {spec!r}\n".replace("'", "") +
            "meshes:\n  - {shape: sphere}\n")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as e:
        load_scene(path)
    msg = str(e.value)
    assert "\n" not in msg and "s.yaml:6:" in msg and "camera.filter" in msg and error in msg, msg


def test_filter_shorthand_and_defaults():
    g = camera(filter="gaussian").filter
    assert (g.type, g.std, g.support) == ("gaussian", 0.5, 2.0)
    assert camera(filter="tent").filter.support == 1.0 and camera().filter.type == "box"
    assert math.isclose(pf.radius("gaussian", 0.3), 1.2)


def test_mitsuba_rfilter_maps_exactly(tmp_path):
    from mcpt.scene import SceneError, load_scene

    def scene(rfilter: str):
        p = tmp_path / "s.xml"
        p.write_text(f'''<scene version="3.0.0"><sensor type="perspective">
            <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
            {rfilter}</film></sensor><shape type="sphere"/></scene>''')
        return p

    assert load_scene(scene("")).camera.filter.describe() == "gaussian (stddev 0.5 px, radius 2 px)"
    assert load_scene(scene('<rfilter type="box"/>')).camera.filter.type == "box"
    f = load_scene(scene('<rfilter type="tent"><float name="radius" value="1.5"/></rfilter>')).camera.filter
    assert (f.type, f.support) == ("tent", 1.5)
    f = load_scene(scene('<rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter>')).camera.filter
    assert (f.type, f.std) == ("gaussian", 0.3)
    for bad, words in (('<rfilter type="mitchell"/>', "pixel filter 'mitchell' is not supported"),
                       ('<rfilter type="gaussian"><float name="radius" value="1"/></rfilter>',
                        "radius: not a parameter of the gaussian filter"),
                       ('<rfilter type="gaussian"><float name="stddev" value="9"/></rfilter>',
                        "must lie in (0, 16] pixels")):
        with pytest.raises(SceneError) as e:
            load_scene(scene(bad))
        msg = str(e.value)
        assert "\n" not in msg and "s.xml:3:" in msg and words in msg, msg


def test_a_sharp_edge_renders_as_the_filters_cdf():
    """An emitter filling the right half of the view (0 bounces): pixel i's value is
    L * P(sample lands right of the edge) = L * (1 - F(edge - centre_i)), F the filter's CDF."""
    from mcpt.api import render_scene
    from mcpt.scene import parse_scene

    w = 16
    text = f"""camera: {{position: [0, 0, 1], look_at: [0, 0, 0], vfov_deg: 90, resolution: [{w}, 2],
          filter: {{type: gaussian, stddev: 0.6}}}}
materials: {{lamp: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}}}
meshes: [{{shape: rectangle, material: lamp, transform: {{translate: [20, 0, -1], scale: [20, 4, 1]}}}}]
"""
    from pathlib import Path
    scene = parse_scene(text, Path("edge.yaml"))
    res, _ = render_scene(scene, spp=1024, bounces=0, seed=2)
    got = res.image[..., 0].astype(np.float64).mean(axis=0)
    # the rectangle spans x in [0, 40] at distance 2 (the view: x in [-16, 16]): the edge at w/2
    # and the right side beyond the image (the filter is cut at the film's edge there).
    centre = np.arange(w) + 0.5
    f = camera(filter={"type": "gaussian", "stddev": 0.6}).filter
    fine = np.linspace(-f.support, f.support, 20001)
    dens = pf.evaluate("gaussian", fine, f.std)
    expected = []
    for c in centre:
        inside = (c + fine >= 0) & (c + fine <= w)           # on the film
        right = inside & (c + fine >= w / 2)
        expected.append(dens[right].sum() / dens[inside].sum())
    np.testing.assert_allclose(got, expected, atol=0.01)
    assert 0.1 < got[w // 2 - 1] < 0.3 and 0.7 < got[w // 2] < 0.9   # the edge is blurred (box: 0, 1)
