"""Opacity cut-outs (issue #22): rays of every kind pass through transparent texels. Mitsuba side
by side: bench/cutout_reference.py (bench/scenes-xml/cutout.xml against its leaf as geometry)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene
from mcpt.scene.mitsuba import scene_data

from .conftest import ROOT
from .draw import render as draw

SCENES = ROOT / "scenes"
FURNACE = """
camera: {{position: [0, 0, 0], look_at: [0, 0, -1], up: [0, 1, 0], vfov_deg: 60, resolution: [24, 24]}}
render: {{spp: {spp}, bounces: 1}}
materials:
  furnace: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
  leaf: {leaf}
meshes:
  - {{file: {root}/furnace/sphere_inward.obj, material: furnace}}
  - {{shape: rectangle, material: leaf, transform: {{translate: [0, 0, -0.5]}}}}
"""


def _render(tmp_path, leaf: str, spp: int = 16, seed: int = 1, **flags):
    from mcpt.api import prepare

    path = tmp_path / "f.yaml"
    path.write_text(FURNACE.format(leaf=leaf, root=SCENES, spp=spp))
    p = prepare(path, feature_flags={"variance": True, **flags})
    try:
        res = draw(p.renderer, spp, seed)
        return res.image[..., 0].astype(np.float64), res.variance[..., 0].astype(np.float64)
    finally:
        p.renderer.release()


def test_camera_sees_the_furnace_through_exactly_the_transparent_squares(gl, tmp_path):
    """vfov 60 at distance 0.5: the view is the plane's square [-h, h]^2, h = 0.5 tan 30 deg, mapped
    linearly onto the image; a 0/1 checkerboard of 32 x 32 squares per [0, 1]^2 of uv (1/16 world
    units) cuts it. Seen pixels: the furnace (1) through holes, the plane (albedo a: it sees
    radiance 1 everywhere, through its holes too) elsewhere; the image mean is their area mix."""
    a = 0.3
    img, _ = _render(tmp_path, f"{{albedo: [{a}, {a}, {a}], opacity: {{type: checkerboard, color0: [1, 1, 1], "
                               "color1: [0, 0, 0], uv: {scale: [16, 16]}}, opacity_cutoff: 0.5}")
    h = 0.5 * math.tan(math.radians(30))
    x = (np.arange(4000) + 0.5) / 4000 * 2 * h - h
    u = (x + 1) / 2 * 16  # the rectangle's uv (v flipped: same parity count by symmetry) times the scale
    hi = (u - np.floor(u)) > 0.5
    opaque = (hi[:, None] == hi[None, :]).mean()  # color0 = 1 where the halves agree
    want = opaque * a + (1 - opaque) * 1.0
    assert 0.3 < opaque < 0.7
    assert abs(img.mean() - want) < 0.01, (img.mean(), want)
    assert abs(img.max() - 1.0) < 1e-6  # a pixel wholly through a hole sees the furnace itself
    assert abs(img.min() - a) < 0.05    # one wholly on the leaf: a, up to its own noise


def test_stochastic_opacity_is_the_mix_in_expectation(gl, tmp_path):
    a = 0.3
    img, var = _render(tmp_path, f"{{albedo: [{a}, {a}, {a}], opacity: {{type: checkerboard, "
                                 "color0: [0.25, 0.25, 0.25], color1: [0.25, 0.25, 0.25]}}", spp=64)
    want = 0.25 * a + 0.75 * 1.0
    se = math.sqrt(var.sum()) / img.size
    assert abs(img.mean() - want) < 4 * se + 1e-4, (img.mean(), want, se)


@pytest.mark.parametrize("sampling", ["nee", "bsdf"])
def test_shadow_rays_and_bsdf_rays_agree_through_the_cutout_leaf(gl, sampling):
    """cutout.xml: the light reaches the room through the leaf's holes only. Light sampling alone
    (shadow rays through the holes) and BSDF sampling alone (paths through them) must give the
    same image as MIS; a shadow ray that ignored the holes would darken "nee" by about half."""
    from mcpt.api import prepare

    scene = load_scene(ROOT / "bench" / "scenes-xml" / "cutout.xml").with_overrides(resolution=(24, 24))
    out = {}
    for mode in ("mis", sampling):
        p = prepare(scene, feature_flags={"variance": True, "sampling": mode})
        try:
            res = draw(p.renderer, 64, 5)
            out[mode] = (res.image.astype(np.float64), res.variance.astype(np.float64))
        finally:
            p.renderer.release()
    (a, va), (b, vb) = out["mis"], out[sampling]
    z = (a.mean() - b.mean()) / (math.sqrt((va + vb).sum()) / a.size)
    assert abs(z) < 4, (sampling, a.mean(), b.mean(), z)


def test_xml_mask_swaps_the_checkerboard_as_mitsubas_eval_1_does(tmp_path):
    camera = ROOT / "tests" / "data" / "mitsuba" / "camera.xml"
    path = tmp_path / "s.xml"

    def xml(opacity: str) -> dict:
        path.write_text(f'<scene version="3.0.0"><include filename="{camera}"/><shape type="rectangle">'
                        f'<bsdf type="mask">{opacity}<bsdf type="diffuse"/></bsdf></shape></scene>')
        return next(iter(scene_data(path)[0]["materials"].values()))["opacity"]

    # Mitsuba 3.9.1, checkerboard color0 1 / color1 0 at uv (0.1, 0.1): eval gives color0, eval_1
    # (what mask reads) color1 = 0 (measured): mcpt's checkerboard, colour lookups only, swaps them.
    board = xml('<texture type="checkerboard" name="opacity"><float name="color0" value="1"/>'
                '<float name="color1" value="0"/></texture>')
    assert board["color0"] == [0.0] * 3 and board["color1"] == [1.0] * 3
    const = xml('<float name="opacity" value="0.3"/>')
    assert const["color0"] == const["color1"] == [0.3] * 3


def test_an_emitter_cannot_be_cut_out(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text(FURNACE.format(leaf="{emission: [1, 1, 1], opacity: {type: checkerboard}}", root=SCENES, spp=1))
    with pytest.raises(SceneError, match=r"opacity.*an emitter cannot be cut out"):
        load_scene(path)


def test_gltf_mask_reads_the_base_colour_alpha_with_its_cutoff(gl, tmp_path):
    import cv2

    from mcpt.shading.texture import load_texture

    from .test_gltf import small_scene

    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., :3] = 200
    rgba[..., 3] = [[255, 0], [40, 255]]
    ok, png = cv2.imencode(".png", rgba)
    b = small_scene()
    b.doc["images"] = [{"bufferView": b.view(png.tobytes()), "mimeType": "image/png"}]
    b.doc["textures"] = [{"source": 0}]
    b.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    b.doc["materials"][0].update(alphaMode="MASK", alphaCutoff=0.3)
    mat = load_scene(b.write_glb(tmp_path / "t.glb")).materials["grey"]
    assert mat.opacity_cutoff == 0.3 and mat.opacity.channel == "alpha"
    t = load_texture(mat.opacity.file, alpha=True, linear=True)
    np.testing.assert_array_equal(t.srgb[::-1, :, 0], rgba[..., 3])  # the alpha, rows bottom-up
    b.doc["materials"][0]["alphaMode"] = "BLEND"
    mat = load_scene(b.write_glb(tmp_path / "t.glb")).materials["grey"]
    assert mat.opacity is not None and mat.opacity_cutoff is None


def test_obj_map_d_cuts_the_mesh_out(gl, tmp_path):
    """An OBJ quad whose MTL gives ``map_d`` (a grey 0/255 image, left half clear): the camera sees
    the furnace through the clear half (stochastic opacity of 0 and 1: no noise from the hash)."""
    import cv2

    mask = np.zeros((64, 64), np.uint8)  # fine enough that bilinear blending stays near u = 1/2
    mask[:, 32:] = 255
    cv2.imwrite(str(tmp_path / "mask.png"), mask)
    (tmp_path / "q.mtl").write_text("newmtl leaf\nKd 0.3 0.3 0.3\nmap_d mask.png\n")
    (tmp_path / "q.obj").write_text("mtllib q.mtl\nv -1 -1 -0.5\nv 1 -1 -0.5\nv 1 1 -0.5\nv -1 1 -0.5\n"
                                     "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl leaf\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
    path = tmp_path / "f.yaml"
    path.write_text(FURNACE.format(leaf="{albedo: [0.3, 0.3, 0.3]}", root=SCENES, spp=16).replace(
        "{shape: rectangle, material: leaf, transform: {translate: [0, 0, -0.5]}}", f"{{file: {tmp_path / 'q.obj'}}}"))
    from mcpt.api import prepare

    p = prepare(path)
    try:
        img = draw(p.renderer, 16, 1).image[..., 0]
    finally:
        p.renderer.release()
    assert p.features.opacity
    left, right = img[:, :10].mean(), img[:, 14:].mean()
    assert abs(left - 1.0) < 1e-6 and abs(right - 0.3) < 0.05, (left, right)
