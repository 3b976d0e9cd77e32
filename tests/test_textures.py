"""Textures beyond an albedo image (issue #22): the procedural checkerboard, UV transforms, and
their mapping from Mitsuba XML (its v-down UVs and checkerboard parity)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene
from mcpt.scene.mitsuba import scene_data
from mcpt.scene.textures import UvTransform
from mcpt.shading.checkerboard import Checkerboard
from mcpt.shading.texture import apply_uv, load_texture, lookup, pack_textures

from .conftest import ROOT, SPOT_TEXTURE
from .draw import render as draw
from .test_materials_util import floats, probe

SCENES = ROOT / "scenes"
C0, C1 = (0.9, 0.8, 0.1), (0.05, 0.2, 0.7)


def test_uv_transform_is_scale_then_rotation_then_offset():
    m = np.array(UvTransform(scale=(2.0, 3.0), rotation=90.0, offset=(0.5, 0.25)).affine())
    got = apply_uv(m, np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]))
    # (1, 0) -> scaled (2, 0) -> rotated CCW (0, 2) -> +offset; (0, 1) -> (0, 3) -> (-3, 0) -> +offset
    np.testing.assert_allclose(got, [[0.5, 2.25], [-2.5, 0.25], [0.5, 0.25]], atol=1e-12)


def test_glsl_checkerboard_and_transformed_images_match_the_reference(gl):
    turn = UvTransform(scale=(3.0, 2.0), rotation=25.0, offset=(0.1, -0.3)).affine()
    textures = [Checkerboard(C0, C1, turn), load_texture(SPOT_TEXTURE, "repeat", "nearest", turn),
                load_texture(SPOT_TEXTURE, "mirror", "bilinear", turn), Checkerboard(C0, C1)]
    buf = pack_textures(textures)
    rng = np.random.default_rng(3)
    for tid, t in enumerate(textures):
        uv = rng.uniform(-2.0, 3.0, (20000, 2)).astype(np.float32)
        items = np.zeros((len(uv), 3), np.uint32)
        items[:, :2] = uv.view(np.uint32)
        items[:, 2] = tid
        got = floats(probe(gl, "texture", items, tbos={"textures": buf}))[:, :3]
        want = lookup(t, uv.astype(np.float64))
        # float32 transform and texel coordinates: points within rounding of a square's or a
        # texel's border may land on either side; a wrong parity or transform is off on ~half.
        ok = np.abs(got - want).max(axis=1) < 5e-4
        assert ok.mean() > 0.998, (tid, ok.mean())
    squares = lookup(textures[3], np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]))
    np.testing.assert_array_equal(squares, [C0, C1, C1, C0])  # [0, 1/2)^2 is color0, Mitsuba's


def _xml(tmp_path, texture: str) -> dict:
    path = tmp_path / "t.xml"
    camera = ROOT / "tests" / "data" / "mitsuba" / "camera.xml"
    path.write_text(f'<scene version="3.0.0"><include filename="{camera}"/><shape type="rectangle">'
                    f'<bsdf type="diffuse">{texture}</bsdf></shape></scene>')
    return scene_data(path)[0]["materials"]


TO_UV = ('<transform name="to_uv"><scale x="3" y="2"/><rotate z="1" angle="20"/>'
         '<translate x="0.15" y="0.3"/></transform>')


def _mitsuba_to_uv():
    """The same to_uv as a 3x3 matrix, built here independently of the loader."""
    c, s = np.cos(np.radians(20.0)), np.sin(np.radians(20.0))
    return np.array([[1, 0, 0.15], [0, 1, 0.3], [0, 0, 1]]) @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) \
        @ np.diag([3.0, 2.0, 1.0])


def test_xml_checkerboard_puts_mitsubas_squares_where_mitsuba_does(tmp_path):
    tex = '<texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.9, 0.8, 0.1"/>' \
          f'<rgb name="color1" value="0.05, 0.2, 0.7"/>{TO_UV}</texture>'
    data = next(iter(_xml(tmp_path, tex).values()))["albedo_texture"]
    board = Checkerboard(tuple(data["color0"]), tuple(data["color1"]), tuple(map(tuple, data["uv"]["matrix"])))
    uv_mitsuba = np.random.default_rng(4).uniform(-1.0, 2.0, (5000, 2))
    st = uv_mitsuba @ _mitsuba_to_uv()[:2, :2].T + _mitsuba_to_uv()[:2, 2]
    hi = (st - np.floor(st)) > 0.5
    want = np.where((hi[:, 0] == hi[:, 1])[:, None], C0, C1)  # checkerboard.cpp eval()
    uv_mcpt = np.stack([uv_mitsuba[:, 0], 1.0 - uv_mitsuba[:, 1]], axis=1)  # mcpt's v points up
    got = lookup(board, uv_mcpt)
    assert (np.abs(got - want).max(axis=1) < 1e-9).mean() > 0.999


def test_xml_bitmap_to_uv_reads_the_texel_mitsuba_reads(tmp_path):
    png = SPOT_TEXTURE
    tex = f'<texture type="bitmap" name="reflectance"><string name="filename" value="{png}"/>{TO_UV}</texture>'
    m = np.array(next(iter(_xml(tmp_path, tex).values()))["albedo_texture"]["uv"]["matrix"])
    uv_mitsuba = np.random.default_rng(5).uniform(-1.0, 2.0, (1000, 2))
    st = uv_mitsuba @ _mitsuba_to_uv()[:2, :2].T + _mitsuba_to_uv()[:2, 2]  # Mitsuba's lookup point
    uv_mcpt = np.stack([uv_mitsuba[:, 0], 1.0 - uv_mitsuba[:, 1]], axis=1)
    read = apply_uv(m, uv_mcpt)  # mcpt's lookup point, v up: the same texel is (s, 1 - t)
    np.testing.assert_allclose(read, np.stack([st[:, 0], 1.0 - st[:, 1]], axis=1), atol=1e-9)


YAML = """
camera: {{position: [0, 0, 3.9], look_at: [0, 0, 0], vfov_deg: 39.3, resolution: [24, 24]}}
render: {{spp: 4, bounces: 3}}
materials:
  white: {{albedo: [0.7, 0.7, 0.7]}}
  light: {{albedo: [0, 0, 0], emission: [15, 15, 15]}}
  floor: {floor}
meshes:
  - {{file: {root}/cornell/white_walls.obj, material: floor}}
  - {{file: {root}/cornell/light.obj, material: light}}
"""


def _scene(tmp_path, floor: str):
    path = tmp_path / "s.yaml"
    path.write_text(YAML.format(floor=floor, root=SCENES))
    return path


def test_yaml_checkerboard_reaches_the_world_and_its_mean_is_the_albedo_column(tmp_path):
    from mcpt.shapes.world import load_world

    world = load_world(load_scene(_scene(tmp_path, "{albedo_texture: {type: checkerboard, color0: [0.9, 0.8, 0.1], "
                                                  "color1: [0.05, 0.2, 0.7], uv: {scale: [4, 4], rotation: 90}}}")))
    (board,) = world.textures
    assert isinstance(board, Checkerboard) and board.color0 == C0
    np.testing.assert_allclose(board.uv, [[0, -4, 0], [4, 0, 0]], atol=1e-12)
    row = world.materials.names.index("floor")
    np.testing.assert_allclose(world.materials.albedo[row], 0.5 * (np.array(C0) + np.array(C1)))


@pytest.mark.parametrize("floor,pattern", [
    ("{albedo_texture: {type: checkerboard, colour0: [1, 1, 1]}}", r"colour0"),
    ("{albedo_texture: {type: checkerboard, color0: [2, 1, 1]}}", r"color0"),
    ("{albedo_texture: {type: checkerboard, uv: {scale: [0, 1]}}}", r"scale \[0.0, 1.0\] flattens"),
    ("{albedo_texture: {type: checkerboard, uv: {scale: [2, 2], matrix: [[1, 0, 0], [0, 1, 0]]}}}",
     r"matrix or scale"),
])
def test_bad_texture_is_one_line_naming_the_key(tmp_path, floor, pattern):
    with pytest.raises(SceneError) as err:
        load_scene(_scene(tmp_path, floor))
    msg = str(err.value)
    assert "\n" not in msg and "albedo_texture" in msg and re.search(pattern, msg), msg


def test_a_one_colour_checkerboard_renders_as_its_colour(gl, tmp_path):
    """Through the whole pipeline (loader, table, buffer, shader): a checkerboard of two equal
    colours gives the plain albedo's pixels, up to float rounding."""
    from mcpt.api import prepare

    images = []
    for floor in ("{albedo: [0.6, 0.3, 0.2]}",
                  "{albedo_texture: {type: checkerboard, color0: [0.6, 0.3, 0.2], color1: [0.6, 0.3, 0.2], "
                  "uv: {scale: [5, 5]}}}"):
        p = prepare(_scene(tmp_path, floor))
        try:
            images.append(draw(p.renderer, 4, 1).image)
        finally:
            p.renderer.release()
    assert images[0].mean() > 0.01
    np.testing.assert_allclose(images[1], images[0], rtol=1e-5, atol=1e-6)


def test_gltf_khr_texture_transform_reads_the_texel_gltf_reads(tmp_path):
    import cv2

    from .test_gltf import small_scene

    ok, png = cv2.imencode(".png", np.full((2, 2, 3), 200, np.uint8))
    b = small_scene()
    b.doc["images"] = [{"bufferView": b.view(png.tobytes()), "mimeType": "image/png"}]
    b.doc["textures"] = [{"source": 0}]
    ext = {"offset": [0.25, -0.5], "rotation": 0.4, "scale": [2.0, 3.0]}
    b.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {
        "index": 0, "extensions": {"KHR_texture_transform": ext}}
    tex = load_scene(b.write_glb(tmp_path / "t.glb")).materials["grey"].albedo_texture
    uv_gltf = np.random.default_rng(6).uniform(-1.0, 2.0, (1000, 2))
    c, s = np.cos(0.4), np.sin(0.4)
    # The extension's README, written out: scale, then rotate by [[c, s], [-s, c]], then offset.
    scaled = uv_gltf * [2.0, 3.0]
    st = np.stack([c * scaled[:, 0] + s * scaled[:, 1], -s * scaled[:, 0] + c * scaled[:, 1]], 1) + [0.25, -0.5]
    read = apply_uv(tex.uv.affine(), np.stack([uv_gltf[:, 0], 1.0 - uv_gltf[:, 1]], axis=1))
    np.testing.assert_allclose(read, np.stack([st[:, 0], 1.0 - st[:, 1]], axis=1), atol=1e-9)
    ext["scale"] = [0.0, 1.0]
    with pytest.raises(SceneError, match=r"KHR_texture_transform: scale \[0.0, 1.0\] flattens"):
        load_scene(b.write_glb(tmp_path / "t.glb"))


def _png_header_only(path, width, height):
    """A PNG whose IHDR claims width x height (its data is a few bytes): what a size check must
    catch before any decoder allocates the pixels."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
                     + chunk(b"IEND", b""))
    return path


def test_an_absurd_texture_is_refused_from_its_header_in_one_located_line(tmp_path):
    """Issue #22: a 20000^2 PNG was killed for memory, a 40000^2 one ended in OpenCV's assertion."""
    from click.testing import CliRunner

    from mcpt.cli.main import main

    _png_header_only(tmp_path / "huge.png", 40000, 40000)
    scene = _scene(tmp_path, "{albedo_texture: huge.png}")
    out = tmp_path / "x.exr"
    r = CliRunner().invoke(main, ["render", str(scene), "--spp", "1", "--resolution", "8x8", "-o", str(out),
                                  "--quiet", "--no-cache"])
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and not out.exists(), r.output
    assert re.search(r"s\.yaml:\d+: materials\.floor\.albedo_texture: .*huge\.png: 40000 x 40000 .* at most "
                     r"67108864", lines[0]), lines[0]


def test_decoded_texels_are_the_srgb_curve_of_each_texel(tmp_path):
    import cv2

    from mcpt.shading.texture import srgb_to_linear

    img = np.random.default_rng(3).integers(0, 256, (37, 23, 3), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "t.png"), img)
    t = load_texture(tmp_path / "t.png")
    np.testing.assert_array_equal(t.decoded(), srgb_to_linear(t.srgb))
    lin = load_texture(tmp_path / "t.png", linear=True)
    np.testing.assert_array_equal(lin.decoded(), lin.srgb / 255.0)
