"""Normal maps (issue #22): tangents from UVs, the shader's mapped normal against closed forms,
the light-leak rules, and bad input. Mitsuba side by side: bench/scenes-xml/normalmap.xml."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene
from mcpt.scene.mitsuba import scene_data
from mcpt.shading.normal_map import pack_tangents, vertex_tangents

from .conftest import ROOT
from .draw import render as draw

SCENES = ROOT / "scenes"
QUAD = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]], np.float64)
FACES = np.array([[0, 1, 2], [0, 2, 3]])


def test_tangents_follow_u_and_the_handedness_of_v():
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float64)
    t = vertex_tangents(QUAD, FACES, uv)
    np.testing.assert_allclose(t, np.tile([1, 0, 0, 1], (4, 1)), atol=1e-12)   # N x T = +y = dp/dv
    t = vertex_tangents(QUAD, FACES, uv * [-1, 1])                               # u mirrored
    np.testing.assert_allclose(t, np.tile([-1, 0, 0, -1], (4, 1)), atol=1e-12)  # N x T = -y, dp/dv = +y
    t = vertex_tangents(QUAD, FACES, uv[:, ::-1])                                # u and v swapped
    np.testing.assert_allclose(t, np.tile([0, 1, 0, -1], (4, 1)), atol=1e-12)


def test_degenerate_uvs_give_no_tangent_and_the_shader_is_told():
    uv = np.array([[0, 0], [1, 0], [1, 0], [0, 0]], np.float64)  # all on v = 0: zero UV area
    t = vertex_tangents(QUAD, FACES, uv)
    assert (t[:, :3] == 0).all()
    packed = pack_tangents(t[FACES])
    assert ((packed[:, 3] >> 3) & 7 == 7).all()  # every corner flagged "no tangent"


def _png(path, rgb, size=4):
    import cv2

    img = np.zeros((size, size, 3), np.uint8)
    img[:] = rgb
    cv2.imwrite(str(path), img[:, :, ::-1])
    return path


def _tilted(n):
    n = np.asarray(n, np.float64) / np.linalg.norm(n)
    return tuple(int(x) for x in np.round((n + 1) / 2 * 255))


FURNACE = """
camera: {{position: [0, 0, 0], look_at: [0, 0, -1], up: [0, 1, 0], vfov_deg: 20, resolution: [12, 12]}}
render: {{spp: 64, bounces: 1}}
materials:
  furnace: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
  plane: {plane}
meshes:
  - {{file: {root}/furnace/sphere_inward.obj, material: furnace}}
  - {{shape: rectangle, material: plane, transform: {{translate: [0, 0, -0.5]}}}}
"""


def _furnace(tmp_path, plane: str, spp: int = 64, seed: int = 1) -> np.ndarray:
    from mcpt.api import prepare

    path = tmp_path / "f.yaml"
    path.write_text(FURNACE.format(plane=plane, root=SCENES))
    p = prepare(path)
    try:
        return draw(p.renderer, spp, seed).image[..., 0].astype(np.float64)
    finally:
        p.renderer.release()


def test_flat_normal_map_gives_the_unmapped_pixels(gl, tmp_path):
    flat = _png(tmp_path / "flat.png", (128, 128, 255))
    plain = _furnace(tmp_path, "{albedo: [0.5, 0.5, 0.5]}")
    mapped = _furnace(tmp_path, f"{{albedo: [0.5, 0.5, 0.5], normal_map: {{file: {flat}, scale: 0}}}}")
    np.testing.assert_allclose(mapped, plain, rtol=1e-5, atol=1e-6)


def _tilted_furnace_answer(n_map: np.ndarray, albedo: float) -> float:
    """a / pi * integral over the upper hemisphere of G(w) max(n . w, 0): the furnace (radiance 1)
    seen on a plane whose mapped normal is n, with the shadowing G (glsl/normal_map.glsl); light
    from below the real surface is cut (no leak). Midpoint rule in (cos theta, phi)."""
    k = 2000
    mu = (np.arange(k) + 0.5) / k
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * 2 * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - m * m)
    w = np.stack([s * np.cos(p), s * np.sin(p), m], -1)
    cos_n = np.maximum(w @ n_map, 0.0)
    alpha2 = min((1 - n_map[2] ** 2) / n_map[2] ** 2 / 8, 1.0)
    g = 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * (1 - m * m) / (m * m)))
    return albedo / math.pi * float((g * cos_n).sum() * (1.0 / k) * (2 * math.pi / (2 * k)))


@pytest.mark.parametrize("n", [(0.5, 0.0, 0.866), (0.0, -0.7, 0.714)])
def test_tilted_constant_normal_map_matches_the_closed_form(gl, tmp_path, n):
    rgb = _tilted(n)
    png = _png(tmp_path / "tilt.png", rgb)
    img = _furnace(tmp_path, f"{{albedo: [0.5, 0.5, 0.5], normal_map: {{file: {png}}}}}", spp=256)
    decoded = np.array(rgb) / 255.0 * 2 - 1
    want = _tilted_furnace_answer(decoded / np.linalg.norm(decoded), 0.5)
    centre = img[3:9, 3:9].ravel()  # the plane fills the middle of the view
    se = centre.std() / math.sqrt(centre.size) + 1e-4
    assert abs(centre.mean() - want) < 4 * se + 5e-4, (centre.mean(), want)
    flat = _tilted_furnace_answer(np.array([0.0, 0.0, 1.0]), 0.5)
    assert want < flat - 0.01  # the tilt is visible: light from below the plane is cut


@pytest.mark.parametrize("rgb,pattern", [
    ((90, 90, 90), r"one channel \(grey\)"),
    ((250, 200, 30), r"not a tangent-space normal map"),
])
def test_images_that_are_no_normal_maps_are_one_located_line(tmp_path, rgb, pattern):
    from mcpt.shapes.world import load_world

    png = _png(tmp_path / "bad.png", rgb)
    path = tmp_path / "s.yaml"
    path.write_text(FURNACE.format(plane=f"{{albedo: [0.5, 0.5, 0.5], normal_map: {png}}}", root=SCENES))
    with pytest.raises(Exception) as err:
        load_world(load_scene(path))
    msg = str(err.value)
    assert "\n" not in msg and "normal_map" in msg and "bad.png" in msg and re.search(pattern, msg), msg


def test_xml_normalmap_maps_to_a_right_handed_linear_normal_map(tmp_path):
    png = _png(tmp_path / "n.png", _tilted((0.3, 0.0, 1.0)))
    camera = ROOT / "tests" / "data" / "mitsuba" / "camera.xml"

    def xml(raw: str) -> dict:
        path = tmp_path / "s.xml"
        path.write_text(f'<scene version="3.0.0"><include filename="{camera}"/><shape type="rectangle">'
                        f'<bsdf type="normalmap"><texture type="bitmap" name="normalmap">'
                        f'<string name="filename" value="{png}"/>{raw}</texture>'
                        '<bsdf type="diffuse"/></bsdf></shape></scene>')
        return next(iter(scene_data(path)[0]["materials"].values()))

    mat = xml('<boolean name="raw" value="true"/>')
    assert mat["type"] == "diffuse" and mat["normal_map"]["handedness"] == "right"
    with pytest.raises(SceneError, match=r"s.xml:1: .*a normal map must be a bitmap with raw=true"):
        xml("")


def test_gltf_normal_texture_becomes_a_normal_map_with_its_scale(tmp_path):
    import cv2

    from .test_gltf import small_scene

    ok, png = cv2.imencode(".png", np.full((2, 2, 3), _tilted((0.2, 0.1, 1.0))[::-1], np.uint8))
    b = small_scene()
    b.doc["images"] = [{"bufferView": b.view(png.tobytes()), "mimeType": "image/png"}]
    b.doc["textures"] = [{"source": 0}]
    b.doc["materials"][0]["normalTexture"] = {"index": 0, "scale": 0.5}
    nm = load_scene(b.write_glb(tmp_path / "t.glb")).materials["grey"].normal_map
    assert nm.scale == 0.5 and nm.handedness == "uv"


# ----------------------------------------------------------------------------------------------
# bump maps (Mitsuba's bumpmap; bench/scenes-xml/bumpmap.xml side by side)


def test_constant_slope_bump_map_matches_the_closed_form(gl, tmp_path):
    """A height ramp along u (256 texels 0..255: d h / d u = 256/255 exactly, linear) tilts the
    rectangle's normal by the same angle everywhere inside it; the furnace then gives the closed
    form of that tilted normal (bumped_normal, the numpy reference of glsl/bump_map.glsl)."""
    import cv2

    from mcpt.shading.bump_map import bumped_normal

    ramp = np.tile(np.arange(256, dtype=np.uint8)[None, :], (8, 1))
    png = tmp_path / "ramp.png"
    cv2.imwrite(str(png), ramp)
    scale = 0.8
    img = _furnace(tmp_path, f"{{albedo: [0.5, 0.5, 0.5], bump_map: {{file: {png}, scale: {scale}, wrap: clamp}}}}",
                   spp=256)
    # mcpt's rectangle (Mitsuba's [-1, 1]^2, uv v flipped): dp/du = (2, 0, 0), dp/dv = (0, -2, 0).
    n = bumped_normal([2, 0, 0], [0, -2, 0], [0, 0, 1], [256 / 255, 0.0], scale)
    assert n[0] < -0.3  # heights rise along +x: the normal leans back
    want = _tilted_furnace_answer(n, 0.5)
    centre = img[3:9, 3:9].ravel()
    se = centre.std() / math.sqrt(centre.size) + 1e-4
    assert abs(centre.mean() - want) < 4 * se + 5e-4, (centre.mean(), want)


def test_xml_bumpmap_maps_scale_and_encoding(tmp_path):
    import cv2

    png = tmp_path / "h.png"
    cv2.imwrite(str(png), np.full((4, 4), 100, np.uint8))
    camera = ROOT / "tests" / "data" / "mitsuba" / "camera.xml"
    path = tmp_path / "s.xml"

    def xml(tex_extra: str) -> dict:
        path.write_text(f'<scene version="3.0.0"><include filename="{camera}"/><shape type="rectangle">'
                        f'<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="{png}"/>'
                        f'{tex_extra}</texture><float name="scale" value="0.2"/><bsdf type="plastic"/></bsdf>'
                        '</shape></scene>')
        return next(iter(scene_data(path)[0]["materials"].values()))

    mat = xml('<boolean name="raw" value="true"/>')
    assert mat["type"] == "plastic" and mat["bump_map"]["scale"] == 0.2 and mat["bump_map"]["encoding"] == "linear"
    assert xml("")["bump_map"]["encoding"] == "srgb"
    with pytest.raises(SceneError, match=r"to_uv on a bump map is not supported"):
        xml('<transform name="to_uv"><scale x="2"/></transform>')
