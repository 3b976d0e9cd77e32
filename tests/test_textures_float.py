"""Float textures (issue #22): EXR, HDR and 16-bit PNG images read as linear float values, one
RGBA32F texel per pixel (mcpt/shading/float_texture.py), filtered like 8-bit ones; the
``encoding`` key of image textures; MTL maps mcpt does not read."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import load_scene
from mcpt.scene.textures import UvTransform
from mcpt.shading.emission_texture import mean_luminance
from mcpt.shading.texture import FLAG_FLOAT, TextureError, load_texture, lookup, pack_textures
from mcpt.shapes.world import load_world

from .conftest import ROOT, SPOT_TEXTURE
from .test_emission_texture import render as render_room
from .test_emission_texture import room, z_of
from .test_materials_util import floats, probe
from .test_textures import _scene as textured_scene


def write_exr(path, rgb) -> None:
    """(H, W, 3) float32 as an EXR, row 0 = the image's top."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, np.float32)}) as f:
        f.write(str(path))


def write_hdr(path, rgb) -> None:
    import cv2

    cv2.imwrite(str(path), np.ascontiguousarray(np.asarray(rgb, np.float32)[:, :, ::-1]))


def write_png16(path, rgb) -> None:
    import cv2

    cv2.imwrite(str(path), np.ascontiguousarray(np.asarray(rgb, np.uint16)[:, :, ::-1]))


def srgb16(c) -> np.ndarray:
    c = np.asarray(c, np.float64) / 65535.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


RNG = np.random.default_rng(22)
HDR_IMG = RNG.uniform(0.0, 40.0, (5, 7, 3)).astype(np.float32)
HDR_IMG[0, 0] = (0.0, 1e-4, 1000.0)
U16_IMG = RNG.integers(0, 65536, (6, 5, 3)).astype(np.uint16)


def test_exr_values_are_kept_exactly_linear_with_v_up(tmp_path):
    write_exr(tmp_path / "a.exr", HDR_IMG)
    t = load_texture(tmp_path / "a.exr")
    assert t.is_float and t.flags & FLAG_FLOAT and (t.width, t.height) == (7, 5)
    np.testing.assert_array_equal(t.values, HDR_IMG[::-1])  # row 0 = bottom, no sRGB curve
    np.testing.assert_array_equal(t.decoded(), HDR_IMG[::-1].astype(np.float64))
    # encoding / linear changes nothing for a float file (Mitsuba: float bitmaps are linear)
    np.testing.assert_array_equal(load_texture(tmp_path / "a.exr", linear=True).values, t.values)
    texels = t.texels().view(np.float32)
    assert texels.shape == (35, 4)
    np.testing.assert_array_equal(texels[:, :3], HDR_IMG[::-1].reshape(-1, 3))


def test_hdr_is_read_linearly(tmp_path):
    write_hdr(tmp_path / "a.hdr", HDR_IMG)
    t = load_texture(tmp_path / "a.hdr")
    assert t.is_float
    # RGBE keeps 8 bits of mantissa per channel against the largest: relative to each pixel's max
    err = np.abs(t.values - HDR_IMG[::-1]) / HDR_IMG[::-1].max(axis=2, keepdims=True)
    assert err.max() < 1.0 / 128


def test_16bit_png_keeps_16_bits_and_is_srgb_decoded_as_mitsuba_does(tmp_path):
    """Mitsuba 3's read_png marks 8- and 16-bit PNGs sRGB alike; the 16 bits are kept (they were
    rounded to 8 before: 1000 / 65535 and 1100 / 65535 were the same texel)."""
    img = U16_IMG.copy()
    img[0, 0], img[0, 1] = (1000, 1000, 1000), (1100, 1100, 1100)
    write_png16(tmp_path / "a.png", img)
    t = load_texture(tmp_path / "a.png")
    assert t.is_float
    np.testing.assert_array_equal(t.values, srgb16(img[::-1]).astype(np.float32))
    assert t.values[-1, 0, 0] != t.values[-1, 1, 0]
    lin = load_texture(tmp_path / "a.png", linear=True)  # normal maps, encoding: linear
    np.testing.assert_array_equal(lin.values, (img[::-1] / 65535.0).astype(np.float32))
    grey_alpha = np.dstack([img, np.full(img.shape[:2], 30000, np.uint16)])
    import cv2

    cv2.imwrite(str(tmp_path / "rgba.png"), grey_alpha[:, :, [2, 1, 0, 3]])
    a = load_texture(tmp_path / "rgba.png", alpha=True)  # the alpha channel, linear
    np.testing.assert_array_equal(a.values, np.full((6, 5, 3), np.float32(30000 / 65535.0)))


@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror"])
@pytest.mark.parametrize("filt", ["bilinear", "nearest"])
def test_glsl_float_lookup_matches_the_reference(gl, tmp_path, wrap, filt):
    """Float textures beside an 8-bit one in one buffer, with and without a UV transform."""
    write_exr(tmp_path / "a.exr", HDR_IMG)
    write_png16(tmp_path / "b.png", U16_IMG)
    turn = UvTransform(scale=(3.0, 2.0), rotation=25.0, offset=(0.1, -0.3)).affine()
    textures = [load_texture(SPOT_TEXTURE, wrap, filt),
                load_texture(tmp_path / "a.exr", wrap, filt), load_texture(tmp_path / "b.png", wrap, filt, turn)]
    buf = pack_textures(textures)
    rng = np.random.default_rng(5)
    for tid, t in enumerate(textures):
        uv = rng.uniform(-2.5, 3.5, (20000, 2)).astype(np.float32)
        items = np.zeros((len(uv), 3), np.uint32)
        items[:, :2] = uv.view(np.uint32)
        items[:, 2] = tid
        got = floats(probe(gl, "texture", items, tbos={"textures": buf}))[:, :3]
        want = lookup(t, uv.astype(np.float64))
        # float32 texel coordinates and transforms: points within rounding of a texel border may
        # land on either side; a wrong texel, layout or curve is off by far more.
        ok = np.abs(got - want).max(axis=1) < 5e-4 * np.maximum(1.0, np.abs(want).max(axis=1))
        assert ok.mean() > 0.998, (tid, ok.mean())


def test_glsl_float_texels_round_trip_exactly(gl, tmp_path):
    """Nearest lookups at texel centres return each float texel bit for bit."""
    write_exr(tmp_path / "a.exr", HDR_IMG)
    t = load_texture(tmp_path / "a.exr", "clamp", "nearest")
    y, x = np.mgrid[0:t.height, 0:t.width]
    uv = np.stack([(x.ravel() + 0.5) / t.width, (y.ravel() + 0.5) / t.height], 1).astype(np.float32)
    items = np.zeros((len(uv), 3), np.uint32)
    items[:, :2] = uv.view(np.uint32)
    got = floats(probe(gl, "texture", items, tbos={"textures": pack_textures([t])}))[:, :3]
    np.testing.assert_array_equal(got, t.values.reshape(-1, 3))


@pytest.mark.parametrize("value,what", [(np.nan, "1 NaN or infinite"), (np.inf, "1 NaN or infinite"),
                                        (-1.0, "1 negative")])
def test_nan_inf_negative_texels_are_refused_in_one_line(tmp_path, value, what):
    img = np.ones((4, 4, 3), np.float32)
    img[1, 2, 1] = value
    write_exr(tmp_path / "bad.exr", img)
    with pytest.raises(TextureError, match=re.escape(f"bad.exr: {what} texels of 4 x 4; a float texture must "
                                                     "hold finite, non-negative values")):
        load_texture(tmp_path / "bad.exr")


def _scene(tmp_path, texture: str, key: str = "albedo_texture"):
    return textured_scene(tmp_path, f"{{{key}: {texture}}}")


def _cli(tmp_path, scene):
    from click.testing import CliRunner

    from mcpt.cli.main import main

    out = tmp_path / "x.exr"
    r = CliRunner().invoke(main, ["render", str(scene), "--spp", "1", "-o", str(out), "--quiet", "--no-cache"])
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and not out.exists(), r.output
    return lines[0]


def test_bad_float_texture_is_one_located_line_exit_2(tmp_path):
    img = np.ones((4, 4, 3), np.float32)
    img[0, 0, 0] = np.nan
    write_exr(tmp_path / "nan.exr", img)
    line = _cli(tmp_path, _scene(tmp_path, "nan.exr"))
    assert re.search(r"s\.yaml:\d+: materials\.floor\.albedo_texture: .*nan\.exr: 1 NaN or infinite", line), line


def test_an_absurd_hdr_texture_is_refused_from_its_header(tmp_path):
    (tmp_path / "huge.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 40000 +X 40000\n")
    line = _cli(tmp_path, _scene(tmp_path, "huge.hdr"))
    assert re.search(r"materials\.floor\.albedo_texture: .*huge\.hdr: 40000 x 40000 .* at most 67108864", line), line


def test_float_path_is_compiled_only_for_scenes_with_a_float_texture(tmp_path):
    """8-bit scenes compile the program they compiled before (bit-identical pixels)."""
    spot = load_world(load_scene(ROOT / "scenes" / "spot.yaml"))
    assert for_world(spot).defines()["MCPT_FLOAT_TEXTURES"] == 0
    write_exr(tmp_path / "a.exr", HDR_IMG / 40.0)
    world = load_world(load_scene(_scene(tmp_path, "a.exr")))
    assert world.textures[0].is_float and for_world(world).defines()["MCPT_FLOAT_TEXTURES"] == 1


def test_emitter_power_and_pick_see_the_float_values(tmp_path):
    """Light sampling's per-triangle power integrates the float texels (values above 1 included)."""
    x, y = np.meshgrid(np.arange(16), np.arange(16))
    img = np.stack([0.5 * x + 0.1, 8.0 - 0.5 * y, np.full(x.shape, 3.0)], -1).astype(np.float32)
    write_exr(tmp_path / "g.exr", img)
    world = load_world(room(tmp_path, f"emission: [2, 2, 2], emission_texture: {tmp_path / 'g.exr'}"))
    tri = world.lights.triangles
    from mcpt.shapes import geometry

    want = mean_luminance(load_texture(tmp_path / "g.exr"), world.uvs[tri].astype(np.float64)) * 2 \
        * geometry.areas(world.tris)[tri]
    np.testing.assert_allclose(world.lights.pmf, want / want.sum(), rtol=1e-9)


def test_constant_exr_emitter_renders_as_its_value(gl, tmp_path):
    """An EXR of constant (2.5, 1.5, 0.25) lights the room as an emitter of that radiance: a
    value no 8-bit texture can hold."""
    c = np.array([2.5, 1.5, 0.25], np.float32)
    write_exr(tmp_path / "c.exr", np.broadcast_to(c, (4, 4, 3)))
    tex, feats = render_room(gl, room(tmp_path, f"emission: [1, 1, 1], emission_texture: {tmp_path / 'c.exr'}"),
                             256, 1)
    assert feats.defines()["MCPT_FLOAT_TEXTURES"] == 1
    plain, _ = render_room(gl, room(tmp_path, f"emission: [{c[0]}, {c[1]}, {c[2]}]"), 256, 2)
    z = z_of(tex, plain)
    assert abs(float(z.mean()) * math.sqrt(z.size)) < 4 and (np.abs(z) < 6).all()


# ------------------------------------------------------------------------------------------------
# issue #22 item 2: encoding: srgb | linear on image texture references


def _grey_png(path, values) -> np.ndarray:
    import cv2

    img = np.asarray(values, np.uint8)
    cv2.imwrite(str(path), img)
    return img


def test_opacity_encoding_linear_reads_c_over_255_and_defaults_are_unchanged(tmp_path):
    img = _grey_png(tmp_path / "o.png", np.arange(64, dtype=np.uint8).reshape(8, 8) * 4)
    for key, linear in (("{file: o.png}", False), ("{file: o.png, encoding: srgb}", False),
                        ("{file: o.png, encoding: linear}", True)):
        world = load_world(load_scene(textured_scene(tmp_path, f"{{albedo: [0.5, 0.5, 0.5], opacity: {key}}}")))
        (t,) = world.textures
        want = img[::-1, :, None].repeat(3, 2) / 255.0
        if not linear:
            want = np.where(want <= 0.04045, want / 12.92, ((want + 0.055) / 1.055) ** 2.4)
        np.testing.assert_array_equal(t.decoded(), want)


def test_one_image_read_two_ways_is_two_textures(tmp_path):
    _grey_png(tmp_path / "o.png", np.full((4, 4), 128, np.uint8))
    world = load_world(load_scene(textured_scene(
        tmp_path, "{albedo_texture: o.png, opacity: {file: o.png, encoding: linear}}")))
    a, b = world.textures
    assert not a.linear and b.linear
    row = world.materials.names.index("floor")
    np.testing.assert_allclose(world.materials.albedo[row], (128 / 255 + 0.055) ** 2.4 / 1.055 ** 2.4)


def test_albedo_linear_and_metallic_roughness_srgb_on_request(tmp_path):
    _grey_png(tmp_path / "o.png", np.full((4, 4), 128, np.uint8))
    world = load_world(load_scene(textured_scene(tmp_path, "{albedo_texture: {file: o.png, encoding: linear}}")))
    np.testing.assert_allclose(world.materials.albedo[world.materials.names.index("floor")], 128 / 255)
    import cv2

    cv2.imwrite(str(tmp_path / "mr.png"), np.full((4, 4, 3), 128, np.uint8))  # RGB: a grey one is refused
    mr = ("{type: metalrough, albedo: [1, 1, 1], metallic_roughness_texture: {file: mr.png%s}}")
    for extra, linear in (("", True), (", encoding: srgb", False)):
        world = load_world(load_scene(textured_scene(tmp_path, mr % extra)))
        assert [t.linear for t in world.textures] == [linear]


def test_bad_encoding_is_one_line_naming_the_key(tmp_path):
    from mcpt.scene import SceneError

    _grey_png(tmp_path / "o.png", np.full((4, 4), 128, np.uint8))
    with pytest.raises(SceneError) as err:
        load_scene(textured_scene(tmp_path, "{albedo_texture: {file: o.png, encoding: gamma}}"))
    msg = str(err.value)
    assert "\n" not in msg and "albedo_texture" in msg and "encoding" in msg, msg


def test_xml_bitmap_raw_true_is_read_linearly(tmp_path):
    from .test_textures import _xml

    tex = ('<texture type="bitmap" name="reflectance"><string name="filename" value="{}"/>'
           '<boolean name="raw" value="{}"/></texture>')
    for raw, encoding in (("true", "linear"), ("false", "srgb")):
        mat = next(iter(_xml(tmp_path, tex.format(SPOT_TEXTURE, raw)).values()))
        assert mat["albedo_texture"]["encoding"] == encoding
