"""The environment (issue #20): a furnace under a constant sky, through the real path tracer."""

import re

import numpy as np
import pytest

from mcpt.errors import McptError
from mcpt.scene import SceneError, parse_scene

from .conftest import ROOT
from .test_lights import render

RHO, SKY = np.array([0.5, 0.7, 0.3]), np.array([1.0, 2.0, 3.0])


def sky_scene(env: str = "{radiance: [1, 2, 3]}", render: str = "{bounces: 4}"):
    text = f"""
camera: {{position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 40, resolution: [24, 24]}}
render: {render}
materials:
  m: {{albedo: [0.5, 0.7, 0.3]}}
meshes:
  - file: models/icosphere.obj
    material: m
environment: {env}
"""
    return parse_scene(text, ROOT / "scenes" / "inline.yaml")


@pytest.mark.parametrize("sampling", ["mis", "nee", "bsdf"])
def test_convex_diffuse_object_under_a_constant_sky_is_rho_l(gl, sampling):
    """A convex object never sees itself: every pixel on it has radiance rho L (each of the three
    estimators, within noise), every pixel beside it the sky's L exactly."""
    res, feats = render(gl, sky_scene(), 64, 11, sampling=sampling)
    assert feats.defines()["MCPT_LIGHT_ENV"] == 1 and feats.defines()["MCPT_LIGHT_AREA"] == 0
    inner = slice(8, 16)  # fully on the sphere (radius ~8.2 pixels about the centre)
    on = res.image[inner, inner].reshape(-1, 3)
    se = np.sqrt(res.variance[inner, inner].reshape(-1, 3).mean(0) / len(on))
    # (BSDF sampling is exact here: cosine-weighted directions of a constant sky, zero variance)
    z = (on.mean(0) - RHO * SKY) / (se + 1e-5 * RHO * SKY)
    assert np.all(np.abs(z) < 4), (on.mean(0), z)
    np.testing.assert_allclose(res.image[:2, :2].reshape(-1, 3), np.broadcast_to(SKY, (4, 3)), rtol=1e-6)


def test_an_invisible_sky_still_lights_the_scene(gl):
    res, _ = render(gl, sky_scene("{radiance: [1, 2, 3], visible: false}"), 16, 12)
    assert np.all(res.image[:2, :2] == 0.0)
    assert res.image[12, 12] == pytest.approx(RHO * SKY, rel=0.1)


def test_zero_sky_is_refused_with_its_line():
    with pytest.raises(SceneError, match=r"inline.yaml:9: environment.radiance: radiance is zero"):
        sky_scene("{radiance: [0, 0, 0]}")


def write_exr(path, img):
    import OpenEXR

    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"RGB": np.ascontiguousarray(img, np.float32)}) as f:
        f.write(str(path))
    return path


def _scene_text(env: str, bounces: int = 4, size: int = 24) -> str:
    """An icosphere of albedo (0.5, 0.7, 0.3) under ``environment: env``."""
    return f"""
camera: {{position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 40, resolution: [{size}, {size}]}}
render: {{bounces: {bounces}}}
materials:
  m: {{albedo: [0.5, 0.7, 0.3]}}
meshes:
  - file: {ROOT / "scenes" / "models" / "icosphere.obj"}
    material: m
environment: {env}
"""


def map_scene(tmp_path, env: str, bounces: int = 4):
    return parse_scene(_scene_text(env, bounces), tmp_path / "inline.yaml")


@pytest.mark.parametrize("sampling", ["mis", "nee"])
def test_convex_diffuse_object_under_a_uniform_map_is_rho_l(gl, tmp_path, sampling):
    """The furnace again with a uniform environment MAP (scale 0.5 of texels [2, 4, 6]): the
    map's evaluation and its sampling tables give rho L too (the file relative to the scene)."""
    write_exr(tmp_path / "flat.exr", np.broadcast_to(np.float32([2, 4, 6]), (8, 16, 3)))
    res, feats = render(gl, map_scene(tmp_path, "{file: flat.exr, scale: 0.5}"), 64, 13, sampling=sampling)
    assert feats.defines()["MCPT_ENVMAP"] == 1
    on = res.image[8:16, 8:16].reshape(-1, 3)
    se = np.sqrt(res.variance[8:16, 8:16].reshape(-1, 3).mean(0) / len(on))
    z = (on.mean(0) - RHO * SKY) / (se + 1e-5 * RHO * SKY)
    assert np.all(np.abs(z) < 4), (on.mean(0), z)
    np.testing.assert_allclose(res.image[:2, :2].reshape(-1, 3), np.broadcast_to(SKY, (4, 3)), rtol=1e-5)


def test_estimators_agree_under_a_map_with_a_sun(gl, tmp_path):
    """A sky with a sun 10^4 times brighter in 4 of 8192 texels, turned 60 degrees: light
    sampling, BSDF sampling and MIS give the same image mean (within noise)."""
    h, w = 64, 128
    img = np.full((h, w, 3), 0.3, np.float32)
    img[h // 2:] = (0.2, 0.15, 0.1)
    img[12:14, 40:42] = (4000, 3600, 3000)
    write_exr(tmp_path / "sky.exr", img)
    sc = map_scene(tmp_path, "{file: sky.exr, transform: {rotate_deg: [0, 60, 0]}}", bounces=2)
    means = {}
    for mode, spp in (("mis", 64), ("nee", 64), ("bsdf", 1024)):
        res, _ = render(gl, sc, spp, 17, sampling=mode)
        means[mode] = (res.image.mean(), float(res.variance.mean()) / res.image.size)
    for mode in ("nee", "bsdf"):
        z = (means[mode][0] - means["mis"][0]) / np.sqrt(means[mode][1] + means["mis"][1])
        assert abs(z) < 4, (mode, means, z)


def test_bad_maps_are_one_located_line(tmp_path):
    from mcpt.shapes.world import load_world

    with pytest.raises(SceneError, match=r"inline.yaml:9: environment.file: environment map not found"):
        map_scene(tmp_path, "{file: nothere.exr}")
    bad = np.ones((4, 8, 3), np.float32)
    bad[1, 2] = np.nan
    bad[2, 3] = -1
    write_exr(tmp_path / "nan.exr", bad)
    with pytest.raises(McptError) as err:
        load_world(map_scene(tmp_path, "{file: nan.exr}"))
    msg = str(err.value)
    assert "\n" not in msg and re.match(r".*inline.yaml:9: environment.file: .*nan.exr", msg), msg
    with pytest.raises(SceneError, match=r"environment.scale: scale is for an environment map"):
        sky_scene("{radiance: [1, 1, 1], scale: 2}")


def test_transparent_film_writes_coverage_as_alpha(tmp_path):
    """render.transparent: camera rays that escape see nothing (RGB 0, alpha 0), the sphere is
    still lit by the sky (rho L, alpha 1), edge pixels are partly covered; EXR A and PNG alpha."""
    import cv2

    from mcpt.api import render_scene
    from mcpt.output.image import read_exr_channels

    scene = sky_scene(render="{bounces: 4, transparent: true}")
    exr, png = tmp_path / "t.exr", tmp_path / "t.png"
    render_scene(scene, outputs=(str(exr), str(png)), spp=32, seed=3)
    ch = read_exr_channels(exr)
    a = ch["A"]
    assert a[0, 0] == 0.0 and ch["R"][0, 0] == 0.0 and np.all(a[9:15, 9:15] == 1.0)
    assert ((a > 0) & (a < 1)).sum() > 8  # the silhouette's pixels, partly covered
    assert ch["G"][12, 12] == pytest.approx(RHO[1] * SKY[1], rel=0.1)
    q = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    assert q.shape == (24, 24, 4) and q[0, 0, 3] == 0 and q[12, 12, 3] == 255
    assert np.array_equal(q[..., 3], np.round(np.clip(a, 0, 1) * 255).astype(np.uint8))


def _hdr_header_only(path, width, height):
    """A Radiance .hdr whose resolution line claims width x height and that holds no pixel: what
    the preflight must refuse before any decoder allocates them."""
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {height} +X {width}\n".encode())
    return path


def _cli_line(tmp_path, env: str):
    """(exit code, the output's non-blank lines, whether the image was written) of ``mcpt render``
    of :func:`map_scene`'s scene with ``environment: env``."""
    from click.testing import CliRunner

    from mcpt.cli.main import main

    scene = tmp_path / "s.yaml"
    scene.write_text(_scene_text(env, size=8))
    out = tmp_path / "x.exr"
    r = CliRunner().invoke(main, ["render", str(scene), "--spp", "1", "-o", str(out), "--quiet", "--no-cache"])
    return r.exit_code, [ln for ln in r.output.splitlines() if ln.strip()], out.exists()


def test_a_map_larger_than_the_memory_is_refused_from_its_header(tmp_path, monkeypatch):
    """Issue #20 "absurdly large (preflight against memory)": an 8192 x 4096 map (2^25 texels,
    within the texel cap) needs ~2.5 GiB through the build; with 1 GiB available it is one located
    line, exit 2, before anything is decoded (the file holds no pixel: a decoder would fail)."""
    from mcpt.gpu import host_memory

    _hdr_header_only(tmp_path / "big.hdr", 8192, 4096)
    monkeypatch.setattr(host_memory, "available_bytes", lambda: 2**30)
    code, lines, written = _cli_line(tmp_path, "{file: big.hdr}")
    assert code == 2 and len(lines) == 1 and not written, lines
    assert re.search(r"s\.yaml:9: environment\.file: .*big\.hdr: 8192 x 4096 needs about 2\.5 GiB to load, "
                     r"more than the 1\.0 GiB of memory available", lines[0]), lines[0]


def test_a_map_over_the_drivers_buffer_texture_limit_is_refused_from_its_header(tmp_path, monkeypatch):
    """Issue #20 "preflight against GL_MAX_TEXTURE_SIZE": the map is a buffer texture, so the
    driver's GL_MAX_TEXTURE_BUFFER_SIZE is the limit (llvmpipe does not clamp a larger buffer).
    A driver reporting 2^20 texels refuses a 2048 x 1024 map in one located line, from the header
    (the file holds no pixel), before the world is built."""
    from mcpt.gpu.context import GLContext

    real = GLContext.limits
    monkeypatch.setattr(GLContext, "limits", lambda self: {**real(self), "max_texture_buffer_size": 1 << 20})
    _hdr_header_only(tmp_path / "wide.hdr", 2048, 1024)
    code, lines, written = _cli_line(tmp_path, "{file: wide.hdr}")
    assert code == 2 and len(lines) == 1 and not written, lines
    assert re.search(r"s\.yaml:9: environment\.file: .*wide\.hdr: 2048 x 1024 = 2097152 texels exceed "
                     r"GL_MAX_TEXTURE_BUFFER_SIZE = 1048576", lines[0]), lines[0]
