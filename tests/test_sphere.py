"""Analytic spheres (mcpt/shapes/sphere.py, glsl/sphere.glsl): which ``shape: sphere`` entries
become one, the same image as the tessellated sphere they replace (uv included), and exact
furnaces from a millimetre to a planet."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import parse_scene
from mcpt.shapes import primitives
from mcpt.shapes.sphere import MAX_SPHERES, pack_spheres, placed_sphere
from mcpt.shapes.world import load_world

from .draw import render as draw
from .test_materials_util import renderer


def _rotation(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    t = math.radians(deg)
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


def test_a_similarity_is_a_sphere_and_anything_else_is_not():
    m = np.eye(4)
    m[:3, :3] = 2.5 * _rotation([1, 2, 3], 40) @ np.diag([1.0, -1.0, 1.0])  # rotation, mirror, scale
    m[:3, 3] = [1, -2, 3]
    s = placed_sphere(m, flip=True)
    assert s is not None and s.radius == pytest.approx(2.5) and s.flip
    np.testing.assert_allclose(s.center, [1, -2, 3])
    np.testing.assert_allclose(s.rotation.T @ s.rotation, np.eye(3), atol=1e-12)
    stretched = m.copy()
    stretched[:3, 0] *= 1.01
    sheared = m.copy()
    sheared[0, 1] += 0.1
    projective = m.copy()
    projective[3, 0] = 0.1
    assert placed_sphere(stretched) is None and placed_sphere(sheared) is None
    assert placed_sphere(projective) is None and placed_sphere(np.zeros((4, 4))) is None


def test_packed_texels_give_the_spheres_own_frame():
    """The centre travels as float64 (exact after rebasing), texels 2-4 hold the rotation's
    columns: (col_i . n) are the sphere's own coordinates of a world direction n, what
    glsl/sphere.glsl sphere_uv takes Mitsuba's uv from."""
    m = np.eye(4)
    rot = _rotation([0.3, -1, 0.2], 70)
    m[:3, :3] = 0.5 * rot
    m[:3, 3] = [6.4e6 + 0.1, 20, 30]
    s = placed_sphere(m, flip=True)
    texels = pack_spheres([s], np.array([7]), origin=np.array([0.0, 19.0, 30.0]))
    assert texels.shape == (5, 4) and texels.dtype == np.uint32
    np.testing.assert_array_equal(texels[:2].reshape(-1)[:6].view(np.float64), [6.4e6 + 0.1, 1.0, 0.0])
    f = texels.view(np.float32)
    assert f[1, 2] == 0.5 and texels[1, 3] == 7 and f[2, 3] == -1.0
    local = np.array([0.48, -0.6, 0.64])
    np.testing.assert_allclose(f[2:, :3] @ (rot @ local), local, atol=1e-6)


SCENE = """
camera: {{position: [0, 1, 4], look_at: [0, 0.5, 0], vfov_deg: 40, resolution: [48, 36]}}
render: {{bounces: 6}}
materials:
  floor: {{albedo: [0.6, 0.6, 0.6]}}
  lamp: {{emission: [4, 4, 4]}}
  glass: {{type: dielectric, ior: 1.5}}
  bumpy: {{albedo: [0.5, 0.5, 0.5], normal_map: {{file: flat.png}}}}
  ramp: {{albedo_texture: {{file: {ramp}}}}}
meshes:
  - {{shape: rectangle, material: floor, transform: {{scale: 5, rotate_deg: [-90, 0, 0]}}}}
{spheres}
environment: {{radiance: [1, 1, 1]}}
"""


def _ramp(tmp_path):
    """An image whose red is u and green is v (8-bit), blue 0.2: any uv mistake shows."""
    u, v = np.meshgrid(np.linspace(0, 1, 64), np.linspace(1, 0, 32))  # row 0 is the top, v = 1
    img = np.stack([0.2 * np.ones_like(u), v, u], -1)  # BGR
    path = tmp_path / "ramp.png"
    cv2.imwrite(str(path), np.round(img * 255).astype(np.uint8))
    cv2.imwrite(str(tmp_path / "flat.png"), np.full((8, 8, 3), (255, 128, 128), np.uint8))  # +z, BGR
    return path


def _world(tmp_path, spheres: str):
    text = SCENE.format(ramp=_ramp(tmp_path), spheres=spheres)
    return load_world(parse_scene(text, tmp_path / "s.yaml"))


def _sphere(material, at=(0.0, 0.5, 0.0), scale="0.5", extra=""):
    return (f"  - {{shape: sphere, material: {material}, transform: {{scale: {scale}, translate: "
            f"[{at[0]}, {at[1]}, {at[2]}]{extra}}}}}")


@pytest.mark.parametrize("material, scale, analytic", [
    ("ramp", "0.5", True), ("glass", "0.5", True),
    ("lamp", "0.5", False),            # an emitter: area lights sample triangles
    ("bumpy", "0.5", False),           # a normal map reads triangle tangents
    ("ramp", "[0.5, 0.5, 0.6]", False),  # an ellipsoid
])
def test_which_spheres_are_analytic(tmp_path, material, scale, analytic):
    w = _world(tmp_path, _sphere(material, scale=scale))
    tessellated = primitives.triangle_count("sphere")
    assert (w.n_spheres, w.n_triangles) == ((1, 2) if analytic else (0, 2 + tessellated))
    assert for_world(w).defines()["MCPT_SPHERES"] == w.n_spheres
    assert w.stats["spheres"] == w.n_spheres


def test_spheres_beyond_the_most_a_program_holds_are_tessellated(tmp_path):
    spheres = "\n".join(_sphere("glass", at=(i, 0.5, -3)) for i in range(MAX_SPHERES + 1))
    w = _world(tmp_path, spheres)
    assert w.n_spheres == MAX_SPHERES and w.n_triangles == 2 + primitives.triangle_count("sphere")
    # the spheres' material reaches the program even where no triangle uses it
    assert for_world(w).defines()["MCPT_MAT_DIELECTRIC"] == 1


def test_a_scene_of_spheres_alone_keeps_them_tessellated(tmp_path):
    text = SCENE.format(ramp=_ramp(tmp_path), spheres=_sphere("glass")).replace(
        "  - {shape: rectangle, material: floor, transform: {scale: 5, rotate_deg: [-90, 0, 0]}}\n", "")
    w = load_world(parse_scene(text, tmp_path / "s.yaml"))
    assert w.n_spheres == 0 and w.n_triangles == primitives.triangle_count("sphere")


def _write_obj(path):
    """The tessellated unit sphere of mcpt/shapes/primitives.py as an OBJ mesh (normals, uvs)."""
    p = primitives.sphere()
    with open(path, "w") as f:
        f.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in p.positions.tolist())
        f.writelines(f"vn {x!r} {y!r} {z!r}\n" for x, y, z in p.normals.tolist())
        f.writelines(f"vt {u!r} {v!r}\n" for u, v in p.uvs.tolist())
        f.writelines("f {0}/{0}/{0} {1}/{1}/{1} {2}/{2}/{2}\n".format(*t) for t in (p.faces + 1).tolist())


def test_the_analytic_sphere_renders_as_the_tessellated_one(gl, tmp_path):
    """A textured diffuse sphere (uv and orientation: the ramp under a turned placement) and a
    glass sphere, analytic, against the same spheres as tessellated OBJ meshes with smooth
    normals: 4x4 block means agree within noise (different seeds), and so does the image."""
    turn = ", rotate_deg: [30, 50, 0]"
    analytic = _sphere("ramp", at=(-0.6, 0.5, 0), extra=turn) + "\n" + _sphere("glass", at=(0.6, 0.5, 0))
    obj = tmp_path / "ball.obj"
    _write_obj(obj)
    meshes = (f"  - {{file: {obj}, material: ramp_s, transform: {{scale: 0.5, translate: [-0.6, 0.5, 0]{turn}}}}}\n"
              f"  - {{file: {obj}, material: glass_s, transform: {{scale: 0.5, translate: [0.6, 0.5, 0]}}}}")
    text = SCENE.format(ramp=_ramp(tmp_path), spheres=meshes).replace(
        "materials:\n", "materials:\n  glass_s: {type: dielectric, ior: 1.5, smooth_normals: true}\n"
        f"  ramp_s: {{albedo_texture: {{file: {_ramp(tmp_path)}}}, smooth_normals: true}}\n")
    results = []
    for world, seed in ((_world(tmp_path, analytic), 1), (load_world(parse_scene(text, tmp_path / "m.yaml")), 2)):
        feats = for_world(world, variance=True)
        r = renderer(gl, world, feats)
        try:
            results.append(draw(r, 256, seed))
        finally:
            r.release()
    a, b = results
    assert _max_block_z(a, b) < 4.5 and abs(_z(a.image, a.variance, b.image, b.variance)) < 3.5


def _z(ia, va, ib, vb):
    """z of the difference of two means of independent renders (0 where both are exact and equal:
    blocks of bare sky)."""
    diff = float(ia.mean() - ib.mean())
    return 0.0 if diff == 0.0 else diff / math.sqrt(float(va.sum() + vb.sum()) / ia.size ** 2 + 1e-300)


def _max_block_z(a, b, n=4):
    """Largest |z| over n x n image blocks and channels (Sidak: 48 tests, 4.5 is p ~ 3e-4)."""
    h, w, _ = a.image.shape
    zs = []
    for i in range(n):
        for j in range(n):
            sl = np.s_[i * h // n:(i + 1) * h // n, j * w // n:(j + 1) * w // n]
            for c in range(3):
                ca, cb = np.s_[sl + (c,)], np.s_[sl + (c,)]
                zs.append(abs(_z(a.image[ca], a.variance[ca], b.image[cb], b.variance[cb])))
    return max(zs)


FURNACE = """
camera: {{position: {eye}, look_at: {at}, up: [0, 0, 1], vfov_deg: {fov}, resolution: [24, 24]}}
render: {{bounces: {bounces}}}
materials:
  grey: {{albedo: [0.5, 0.5, 0.5]}}
  glass: {{type: dielectric, ior: 1.5}}
  far: {{albedo: [0.5, 0.5, 0.5]}}
meshes:
  - {{shape: sphere, material: {material}, transform: {{scale: {r}, translate: {c}}}}}
  - {{shape: rectangle, material: far, transform: {{scale: 0.001, translate: [0, 0, {behind}]}}}}
environment: {{radiance: [1, 1, 1]}}
"""


@pytest.mark.parametrize("r, eye_above, fov", [
    (1e-3, 0.5e-3, 60.0),   # a millimetre sphere seen from half a radius
    (1.0, 0.5, 60.0),
    (6.4e6, 2.0, 120.0),    # a planet, the camera two units above its surface looking down
])
@pytest.mark.parametrize("material, want", [("grey", 0.5), ("glass", 1.0)])
def test_spheres_in_a_furnace_at_every_scale(gl, tmp_path, r, eye_above, fov, material, want):
    """A convex diffuse sphere of albedo 1/2 under a uniform sky L = 1 has radiance 1/2 at every
    point (it sees only the sky); a glass sphere returns every path to the sky: L = 1. The sphere
    fills the frame. A ray that found the surface it leaves again (self-intersection: the
    rounding of |f|^2 - r^2 grows with r, the origin offset with the distance from the camera)
    would darken the image."""
    c = [0.0, 0.0, 0.0]
    eye = [0.0, r + eye_above, 0.0]
    text = FURNACE.format(eye=eye, at=c, fov=fov, bounces=32 if material == "glass" else 1,
                          material=material, r=r, c=c, behind=-1e3 * r)
    world = load_world(parse_scene(text, tmp_path / "furnace.yaml"))
    assert world.n_spheres == 1
    feats = for_world(world, variance=True)
    rd = renderer(gl, world, feats)
    try:
        res = draw(rd, 64, 5)
    finally:
        rd.release()
    assert res.dropped_samples == 0
    z = (res.image.mean() - want) / math.sqrt(res.variance.sum() / res.image.size ** 2 + 1e-30)
    assert abs(res.image.mean() - want) < 0.01 * want and abs(z) < 4.0
