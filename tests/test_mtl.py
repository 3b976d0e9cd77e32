"""OBJ materials from the MTL file (issue #13): ``map_Kd`` textures (paths relative to the MTL, sRGB),
``map_Ke`` / ``Ke``, the YAML overriding them, and one clear line for a missing texture file."""

import logging

import numpy as np
import pytest

from mcpt.errors import McptError
from mcpt.gpu.features import for_world
from mcpt.scene import parse_scene
from mcpt.shading.lights import LUMINANCE
from mcpt.shading.texture import srgb_to_linear
from mcpt.shapes import obj
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .test_materials_render import render

ENCLOSURE = ROOT / "scenes" / "furnace" / "sphere_inward.obj"
# An 8 x 8 image of four 4 x 4 blocks (sRGB); the top-left block is the image's first rows.
BLOCKS = {"top-left": (250, 20, 20), "top-right": (20, 200, 20), "bottom-left": (20, 20, 220),
          "bottom-right": (240, 240, 60)}


def _textured_quad(folder, *, mtl_extra="", texture="tex/blocks.png", write_png=True):
    """A unit quad with UVs (u right, v up) whose MTL names a texture in a sub-folder of the MTL's."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    (folder / "quad.obj").write_text(
        "mtllib materials/quad.mtl\n"
        "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "usemtl painted\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
    (folder / "materials").mkdir(exist_ok=True)
    (folder / "materials" / "quad.mtl").write_text(
        f"# a test material\nnewmtl painted\nKd 0.5 0.5 0.5\nmap_Kd -s 1 1 1 {texture}\n{mtl_extra}")
    if write_png:
        img = np.zeros((8, 8, 3), np.uint8)
        img[:4, :4], img[:4, 4:] = BLOCKS["top-left"], BLOCKS["top-right"]
        img[4:, :4], img[4:, 4:] = BLOCKS["bottom-left"], BLOCKS["bottom-right"]
        (folder / "materials" / "tex").mkdir(exist_ok=True)
        cv2.imwrite(str(folder / "materials" / "tex" / "blocks.png"), img[:, :, ::-1])
    return folder / "quad.obj"


def _scene(quad, material_line="", tmp_path=None):
    """The quad fills a 16 x 16 view from 1 unit away, inside a black enclosure of radiance 1."""
    text = f"""
camera: {{position: [0, 0, 1], look_at: [0, 0, 0], vfov_deg: 53.130102, resolution: [16, 16]}}
render: {{bounces: 1}}
materials:
  sky: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
{material_line}
meshes:
  - {{file: {ENCLOSURE}, material: sky, transform: {{scale: 3}}}}
  - {{file: {quad}{', material: q' if material_line else ''}}}
"""
    return parse_scene(text, (tmp_path or ROOT / "scenes") / "inline.yaml")


def test_map_kd_is_read_relative_to_the_mtl_with_options():
    maps = obj.ObjFile.read(ROOT / "scenes" / "models" / "checker-cube" / "cube.obj").mtl.maps
    tmap = maps["checker"]["map_kd"]
    assert tmap.declared_in.name == "cube.mtl" and tmap.keyword == "map_Kd"
    assert tmap.file == ROOT / "scenes" / "models" / "checker-cube" / "checker.png"
    assert obj.map_file("-s 1 1 1 -o 0.5 -bm 2 -clamp on my texture.png") == "my texture.png"
    assert obj.map_file("-s 2 tex.png") == "tex.png"


def test_obj_with_map_kd_renders_its_texture(gl, tmp_path):
    """BSDF sampling only, one bounce: a white-lit Lambertian pixel is its albedo exactly, so each
    block's inner pixels are the block's sRGB colour decoded (the top-left block at the top left:
    v points up, the image's first row is the top)."""
    world = load_world(_scene(_textured_quad(tmp_path / "m"), tmp_path=tmp_path))
    f = for_world(world)
    assert f.textures and len(world.textures) == 1 and world.uvs is not None
    res, _ = render(gl, _scene(_textured_quad(tmp_path / "m"), tmp_path=tmp_path), 4, 1, sampling="bsdf")
    img = res.image.astype(np.float64)
    inner = {"top-left": img[2:6, 2:6], "top-right": img[2:6, 10:14], "bottom-left": img[10:14, 2:6],
             "bottom-right": img[10:14, 10:14]}
    for name, px in inner.items():
        want = srgb_to_linear(np.asarray(BLOCKS[name]))
        np.testing.assert_allclose(px.reshape(-1, 3), np.broadcast_to(want, (16, 3)), rtol=1e-5, err_msg=name)


def test_yaml_albedo_overrides_the_mtl_texture(gl, tmp_path):
    quad = _textured_quad(tmp_path / "m")
    world = load_world(_scene(quad, "  q: {albedo: [0.25, 0.5, 0.75]}", tmp_path))
    assert not world.textures and not for_world(world).textures
    res, _ = render(gl, _scene(quad, "  q: {albedo: [0.25, 0.5, 0.75]}", tmp_path), 2, 1, sampling="bsdf")
    np.testing.assert_allclose(res.image[4:12, 4:12].reshape(-1, 3), np.broadcast_to([0.25, 0.5, 0.75], (64, 3)),
                               rtol=1e-6)
    # A YAML material silent on the albedo takes the MTL's texture (and keeps its own type).
    world = load_world(_scene(quad, "  q: {type: plastic}", tmp_path))
    mt = world.materials
    used = [i for i in mt.used(world.tri_material) if mt.names[i] == "q"]
    assert len(world.textures) == 1 and [(mt.types[i], mt.texture[i]) for i in used] == [("plastic", 0)]


def test_missing_mtl_texture_is_one_line_naming_obj_mtl_and_file(tmp_path):
    quad = _textured_quad(tmp_path / "m", texture="tex/gone.png", write_png=False)
    with pytest.raises(McptError) as e:
        load_world(_scene(quad, tmp_path=tmp_path))
    msg = str(e.value)
    assert "\n" not in msg
    assert "quad.obj" in msg and "quad.mtl" in msg and "gone.png" in msg and "map_Kd" in msg, msg
    # Overridden by the YAML, the missing texture is never needed.
    load_world(_scene(quad, "  q: {albedo: [1, 1, 1]}", tmp_path))


def test_map_ke_is_an_emission_texture_scaled_by_ke(tmp_path, caplog):
    """Issue #22: map_Ke is read per hit (emission_texture) with Ke its scale; the light table
    carries the textured power (the texture's mean over the quad's UV square x Ke x area)."""
    quad = _textured_quad(tmp_path / "m", mtl_extra="Ke 2 2 2\nmap_Ke tex/blocks.png\n")
    with caplog.at_level(logging.WARNING, logger="mcpt"):
        world = load_world(_scene(quad, tmp_path=tmp_path))
    i = world.materials.names.index("painted")
    assert tuple(world.materials.emission[i]) == (2, 2, 2) and world.materials.emission_texture[i] >= 0
    assert "not supported" not in caplog.text
    lights = world.lights
    mine = world.tri_material[lights.triangles] == i
    lum = {k: srgb_to_linear(np.array(v)) @ LUMINANCE for k, v in BLOCKS.items()}
    # The UV triangle u > v holds the bottom-right block and halves of its two neighbours.
    half = 0.25 * (lum["bottom-left"] + lum["top-right"])
    want = sorted([0.5 * lum["bottom-right"] + half, 0.5 * lum["top-left"] + half])  # x Ke 2 x area 0.5
    got = sorted(lights.pmf[:lights.count][mine] * lights.total_power)
    # Within the bilinear blur at the blocks' edges (and the repeat wrap): a uniform pick is 2x off.
    np.testing.assert_allclose(got, want, rtol=0.1)


def test_load_world_reads_each_obj_and_mtl_once(tmp_path, monkeypatch):
    """mcpt reads an OBJ's bytes once for all its checks (bad vertices, MTL names, precision) and
    each MTL once (Assimp opens them on its own, by path: assimp-py cannot read from memory)."""
    from collections import Counter
    from pathlib import Path

    quad = _textured_quad(tmp_path / "m", mtl_extra="Ke 0.5 0.5 0.5\n")
    reads: Counter = Counter()
    read_bytes, read_text = Path.read_bytes, Path.read_text

    def count_bytes(self):
        reads[self.name] += 1
        return read_bytes(self)

    def count_text(self, *args, **kwargs):
        reads[self.name] += 1
        return read_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "read_bytes", count_bytes)
    monkeypatch.setattr(Path, "read_text", count_text)
    world = load_world(_scene(quad, tmp_path=tmp_path))
    assert reads["quad.obj"] == 1 and reads["quad.mtl"] == 1, reads
    assert reads[ENCLOSURE.name] == 1, reads
    # What was read once still means what it did: map_Kd (textured), Ke (emission).
    i = world.materials.names.index("painted")
    assert world.materials.texture[i] >= 0 and tuple(world.materials.emission[i]) == (0.5, 0.5, 0.5)


def test_mtl_maps_mcpt_does_not_read_are_said_once(tmp_path, caplog):
    """Issue #22: an MTL's bump / normal / PBR / specular maps are not read; one warning per MTL
    file names them and their materials (they used to be dropped without a word)."""
    extra = "map_Bump -bm 0.5 tex/blocks.png\nnorm tex/blocks.png\nmap_Pr tex/blocks.png\nmap_Ks tex/blocks.png\n"
    quad = _textured_quad(tmp_path / "m", mtl_extra=extra)
    with caplog.at_level(logging.WARNING, logger="mcpt"):
        load_world(_scene(quad, tmp_path=tmp_path))
    said = [r.getMessage() for r in caplog.records if "ignored by mcpt" in r.getMessage()]
    assert len(said) == 1, said
    assert "quad.mtl" in said[0] and all(k in said[0] for k in ("map_bump", "norm", "map_pr", "map_ks"))
    assert "painted" in said[0] and "\n" not in said[0]
