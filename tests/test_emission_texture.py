"""Emission textures (issue #22): radiance read per hit, light sampling by each triangle's textured
power (mcpt/shading/emission_texture.py), MIS consistent between the two strategies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import parse_scene
from mcpt.shading.emission_texture import mean_luminance, subdivision_points
from mcpt.shading.lights import LUMINANCE
from mcpt.shading.texture import load_texture, lookup
from mcpt.shapes import geometry
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .test_materials_util import renderer


def grid_obj(path, n: int = 3) -> None:
    """An n x n grid of quads over [-0.5, 0.5]^2 (z = 0, front +z) with UVs [0, 1]^2."""
    lines = []
    for j in range(n + 1):
        for i in range(n + 1):
            lines += [f"v {i / n - 0.5} {j / n - 0.5} 0", f"vt {i / n} {j / n}"]
    for j in range(n):
        for i in range(n):
            a, d = j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1
            b, c = a + 1, d + 1
            lines += [f"f {a}/{a} {b}/{b} {c}/{c}", f"f {a}/{a} {c}/{c} {d}/{d}"]
    path.write_text("\n".join(lines) + "\n")


def image(path, rgb) -> None:
    import cv2

    cv2.imwrite(str(path), np.ascontiguousarray(np.asarray(rgb, np.uint8)[::-1, :, ::-1]))


def gradient(path) -> None:
    """A 16 x 16 image: red rising left to right, green top to bottom, a dark corner."""
    x, y = np.meshgrid(np.arange(16), np.arange(16))
    rgb = np.stack([16 * x + 8, 255 - 16 * y, np.full_like(x, 60)], -1)
    rgb[:4, :4] = 0
    image(path, rgb)


ROOM = """
camera: {{position: [0, 0, 3], look_at: [0, 0, 0], vfov_deg: 40, resolution: [16, 16]}}
render: {{bounces: 2}}
materials:
  grey: {{albedo: [0.5, 0.5, 0.5]}}
  lamp: {{albedo: [0, 0, 0], {lamp}}}
meshes:
  - file: models/quad.obj
    material: grey
    transform: {{scale: 6}}
  - file: {grid}
    material: lamp
    transform: {{translate: [0.3, 0, 0.5], rotate_deg: [170, 0, 0], scale: 1.5}}
"""


def room(tmp_path, lamp: str):
    grid_obj(tmp_path / "grid.obj")
    return parse_scene(ROOM.format(lamp=lamp, grid=tmp_path / "grid.obj"), ROOT / "scenes" / "inline.yaml")


def render(gl, sc, spp, seed, **flags):
    world = load_world(sc)
    feats = for_world(world, variance=True, **flags)
    r = renderer(gl, world, feats)
    try:
        return draw(r, spp, seed), feats
    finally:
        r.release()


def z_of(a, b) -> np.ndarray:
    """Per-pixel z of two independent renders' difference."""
    return (a.image - b.image) / np.sqrt(a.variance + b.variance + 1e-12)


def test_subdivision_points_are_the_sub_triangles_centroids():
    for s in (1, 2, 5):
        b = subdivision_points(s)
        assert len(b) == s * s and (b > 0).all() and (b.sum(1) < 1).all()
        np.testing.assert_allclose(b.mean(0), [1 / 3, 1 / 3], atol=1e-12)  # the centroid of the whole


def test_triangle_power_matches_a_brute_force_integral(tmp_path):
    """The quadrature of the texture's luminance over UV triangles against 400 000 uniform points
    each (Monte Carlo in numpy, independent of the subdivision)."""
    gradient(tmp_path / "g.png")
    tex = load_texture(tmp_path / "g.png")
    rng = np.random.default_rng(1)
    uvs = rng.uniform(-0.3, 1.3, (6, 3, 2))
    got = mean_luminance(tex, uvs)
    u = rng.random((400_000, 2))
    fold = u.sum(1) > 1
    u[fold] = 1 - u[fold]  # uniform on the triangle
    for k in range(len(uvs)):
        pts = uvs[k, 0] + u[:, :1] * (uvs[k, 1] - uvs[k, 0]) + u[:, 1:] * (uvs[k, 2] - uvs[k, 0])
        lum = lookup(tex, pts) @ LUMINANCE
        tol = 4 * lum.std() / math.sqrt(len(lum)) + 3e-3 * lum.mean()
        assert abs(got[k] - lum.mean()) < tol, (k, got[k], lum.mean())


def test_light_pick_follows_the_textured_power(tmp_path):
    """The grid's 18 triangles are picked by texture x area; a constant texture: by area alone."""
    gradient(tmp_path / "g.png")
    sc = room(tmp_path, f"emission: [2, 2, 2], emission_texture: {tmp_path / 'g.png'}")
    world = load_world(sc)
    lights = world.lights
    assert lights.count == 18
    tri = lights.triangles
    uvs = world.uvs[tri].astype(np.float64)
    want = mean_luminance(load_texture(tmp_path / "g.png"), uvs) * 2 * geometry.areas(world.tris)[tri]
    np.testing.assert_allclose(lights.pmf, want / want.sum(), rtol=1e-9)
    assert lights.pmf.max() / lights.pmf.min() > 3  # the texture, not the area, decides


def test_constant_texture_renders_as_its_colour(gl, tmp_path):
    """A texture of constant c x scale s: the same picture as an untextured emitter of c s."""
    c = np.array([200, 120, 40])
    image(tmp_path / "c.png", np.broadcast_to(c, (4, 4, 3)))
    lin = np.where(c / 255 <= 0.04045, c / 255 / 12.92, ((c / 255 + 0.055) / 1.055) ** 2.4) * 3
    tex, feats = render(gl, room(tmp_path, f"emission: [3, 3, 3], emission_texture: {tmp_path / 'c.png'}"), 256, 1)
    assert feats.defines()["MCPT_EMISSION_TEXTURES"] == 1
    plain, f2 = render(gl, room(tmp_path, f"emission: [{lin[0]}, {lin[1]}, {lin[2]}]"), 256, 2)
    assert f2.defines()["MCPT_EMISSION_TEXTURES"] == 0
    z = z_of(tex, plain)
    assert abs(float(z.mean()) * math.sqrt(z.size)) < 4 and (np.abs(z) < 6).all()


@pytest.mark.parametrize("sampling", ["nee", "bsdf"])
def test_nee_bsdf_and_mis_agree_on_a_textured_emitter(gl, tmp_path, sampling):
    gradient(tmp_path / "g.png")
    sc = room(tmp_path, f"emission: [4, 4, 4], emission_texture: {tmp_path / 'g.png'}")
    mis, _ = render(gl, sc, 256, 3, sampling="mis")
    other, _ = render(gl, sc, 256 if sampling == "nee" else 1024, 4, sampling=sampling)
    z = z_of(mis, other)
    mean_z = float(z.mean()) * math.sqrt(z.size)
    assert abs(mean_z) < 4, mean_z
    assert np.abs(z).max() < 6


def test_mitsuba_area_emitter_with_a_bitmap_radiance():
    from mcpt.scene.mitsuba import scene_data

    mats = scene_data(ROOT / "bench" / "scenes-xml" / "emission-texture.xml")[0]["materials"]
    lamps = [m for m in mats.values() if "emission_texture" in m]
    assert len(lamps) == 2 and all(m["emission"] == [1.0, 1.0, 1.0] for m in lamps)
    assert {m["emission_texture"].get("filter", "bilinear") for m in lamps} == {"bilinear", "nearest"}
    assert all(m["emission_texture"]["file"].endswith("emission-gradient.png") for m in lamps)


def test_every_buffer_has_its_own_texture_unit():
    from mcpt.gpu.tbo import UNITS

    assert len(set(UNITS.values())) == len(UNITS), UNITS


def test_uber_shader_renders_a_textured_emitter_like_the_specialised_one(gl, tmp_path):
    from mcpt.prepare import prepare

    gradient(tmp_path / "g.png")
    sc = room(tmp_path, f"emission: [4, 4, 4], emission_texture: {tmp_path / 'g.png'}")
    out = []
    for mode, seed in (("scene", 5), ("all", 6)):
        p = prepare(sc, features_mode=mode, feature_flags={"variance": True})
        try:
            out.append(draw(p.renderer, 256, seed))
        finally:
            p.renderer.release()
    z = z_of(*out)
    assert abs(float(z.mean()) * math.sqrt(z.size)) < 4 and np.abs(z).max() < 6


def test_glsl_light_pick_follows_the_textured_power_table(gl, tmp_path):
    """chi^2 of the shader's light pick (tests/glsl/probe_sample.frag mode 3) against the
    textured power table of the grid emitter."""
    from .test_materials_util import chi2_test, floats, probe, uniform_numbers

    gradient(tmp_path / "g.png")
    lights = load_world(room(tmp_path, f"emission: [2, 2, 2], emission_texture: {tmp_path / 'g.png'}")).lights
    n = 1 << 18
    out = probe(gl, "light", uniform_numbers(n, 1, seed=8), tbos={"lights": lights.pack()}, light_count=lights.count)
    idx, pmf = out[:, 0].astype(np.int64), floats(out)[:, 1]
    slot = np.searchsorted(lights.triangles, idx)
    p, stat, dof = chi2_test(np.bincount(slot, minlength=lights.count), lights.pmf * n)
    assert p > 1e-3, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"
    np.testing.assert_allclose(pmf, lights.pmf[slot], rtol=1e-6)
