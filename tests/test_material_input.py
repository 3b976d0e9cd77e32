"""Bad material input (issue #21 "What bad input gets"): one located line, exit 2, nothing written.
Items 1-3 of the follow-up on issue #21: a grey metallic-roughness texture, glTF factors above 1,
YAML ior below 1 / smooth plastic with ior 1."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.cli.main import main

from .gltf_files import GltfBuilder

QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
FACES = np.array([[0, 1, 2], [0, 2, 3]], np.uint16)
UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)

SCENE = """camera: {{position: [0, 0, 3], look_at: [0, 0, 0], up: [0, 1, 0], vfov_deg: 60, resolution: [8, 8]}}
render: {{spp: 1, bounces: 2, seed: 0}}
materials:
  m: {material}
  light: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
meshes:
  - {{shape: rectangle, material: m}}
  - {{shape: rectangle, material: light, transform: {{translate: [0, 0, 4], rotate_deg: [180, 0, 0]}}}}
"""


def png_grey_alpha(path: Path, size: int = 4) -> Path:
    """A grey + alpha PNG (colour type 4; OpenCV cannot write one, and reads it back as BGRA)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    rows = b"".join(b"\0" + bytes([128, 255]) * size for _ in range(size))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 4, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
    return path


def images(folder: Path) -> None:
    cv2.imwrite(str(folder / "grey8.png"), np.full((4, 4), 128, np.uint8))
    cv2.imwrite(str(folder / "grey16.png"), np.full((4, 4), 30000, np.uint16))
    cv2.imwrite(str(folder / "grey.jpg"), np.full((4, 4), 128, np.uint8))
    png_grey_alpha(folder / "greyalpha.png")
    cv2.imwrite(str(folder / "rgb.png"), np.full((4, 4, 3), 128, np.uint8))
    cv2.imwrite(str(folder / "rgba.png"), np.full((4, 4, 4), 128, np.uint8))


def render(scene: Path, out: Path):
    return CliRunner().invoke(main, ["render", str(scene), "-o", str(out), "--quiet"], catch_exceptions=False)


def one_error(r, out: Path) -> str:
    """The ``mcpt: error:`` line of a refused render: exit 2, that line alone, no image written."""
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("mcpt: error:"), lines
    assert not out.exists()
    return lines[0]


def lacking(line: str, *needles: str) -> list:
    """The needles ``line`` does not hold (``assert not lacking(line, ...)``)."""
    return [n for n in needles if n not in line]


def yaml_scene(folder: Path, material: str) -> Path:
    path = folder / "s.yaml"
    path.write_text(SCENE.format(material=material))
    return path


def gltf_scene(folder: Path, material: dict, image: str | None = None) -> Path:
    b = GltfBuilder()
    if image:
        b.doc["images"] = [{"uri": image}]
        b.doc["textures"] = [{"source": 0}]
    m = b.material(**material)
    lamp = b.material(emissiveFactor=[1, 1, 1])
    b.node(mesh=b.mesh(QUAD, FACES, m, uvs=UV))
    b.node(mesh=b.mesh(QUAD + [0, 0, 4], FACES[:, ::-1], lamp))
    b.node(camera=b.camera(1.0), translation=[0, 0, 3])
    return b.write_gltf(folder / "s.gltf")


# ---- item 1: a metallic-roughness texture must be RGB(A) ------------------------------------------

@pytest.mark.parametrize("image, kind", [("grey8.png", "grey image (1 channel)"),
                                         ("grey16.png", "grey image (1 channel)"),
                                         ("grey.jpg", "grey image (1 channel)"),
                                         ("greyalpha.png", "grey + alpha image (2 channels)")])
def test_grey_metallic_roughness_texture_is_refused(tmp_path, image, kind):
    images(tmp_path)
    out = tmp_path / "o.exr"
    scene = yaml_scene(tmp_path, f"{{type: metalrough, metallic_roughness_texture: {image}}}")
    line = one_error(render(scene, out), out)
    assert not lacking(line, "s.yaml:4: materials.m.metallic_roughness_texture", image, kind,
                       "must be RGB or RGBA", "blue", "green", "mistake"), line
    scene = gltf_scene(tmp_path, {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}}}, image)
    line = one_error(render(scene, out), out)
    assert not lacking(line, "s.gltf", "metallic_roughness_texture", image, kind), line


@pytest.mark.parametrize("image", ["rgb.png", "rgba.png"])
def test_colour_metallic_roughness_texture_renders(tmp_path, image):
    images(tmp_path)
    out = tmp_path / "o.exr"
    r = render(yaml_scene(tmp_path, f"{{type: metalrough, metallic_roughness_texture: {image}}}"), out)
    assert r.exit_code == 0, r.output
    assert out.exists()


# ---- item 2: glTF metallicFactor / roughnessFactor above 1 are refused, not clamped ------------------

@pytest.mark.parametrize("key, value", [("roughnessFactor", 1.5), ("metallicFactor", 2.0), ("roughnessFactor", -0.5)])
def test_gltf_unit_factors_out_of_range_are_refused(tmp_path, key, value):
    out = tmp_path / "o.exr"
    scene = gltf_scene(tmp_path, {"pbrMetallicRoughness": {key: value}})
    line = one_error(render(scene, out), out)
    assert not lacking(line, "s.gltf: materials[0]", f"{key} {value:g}"), line
    assert "[0, 1]" in line or ">= 0" in line


def test_gltf_unit_factors_at_one_render(tmp_path):
    out = tmp_path / "o.exr"
    scene = gltf_scene(tmp_path, {"pbrMetallicRoughness": {"roughnessFactor": 1, "metallicFactor": 1.0}})
    assert render(scene, out).exit_code == 0 and out.exists()


# ---- item 3: ior below 1 said in words; smooth plastic refuses ior 1 as roughplastic does ------------

@pytest.mark.parametrize("material", ["dielectric", "plastic", "roughplastic", "thindielectric"])
@pytest.mark.parametrize("ior, needles", [(0.67, ["ior 0.67 < 1 is not supported", "relative index",
                                                  "denser medium must be inside", "flip the normals", "1.493"]),
                                         (0, ["ior 0 is no index of refraction", "relative index"]),
                                         (-1.5, ["ior -1.5 is no index of refraction"])])
def test_ior_below_one_says_what_it_means(tmp_path, material, ior, needles):
    out = tmp_path / "o.exr"
    rough = ", roughness: 0.3" if material == "roughplastic" else ""
    scene = yaml_scene(tmp_path, f"{{type: {material}, ior: {ior}{rough}}}")
    line = one_error(render(scene, out), out)
    assert not lacking(line, "s.yaml:4: materials.m.ior", *needles), line


@pytest.mark.parametrize("material", ["plastic", "roughplastic"])
def test_plastics_refuse_ior_one_alike(tmp_path, material):
    out = tmp_path / "o.exr"
    rough = ", roughness: 0.3" if material == "roughplastic" else ""
    line = one_error(render(yaml_scene(tmp_path, f"{{type: {material}, ior: 1{rough}}}"), out), out)
    assert "s.yaml:4: materials.m.ior" in line, line
    assert line.endswith("ior 1 is no interface (the same index on both sides: the surface would be invisible); "
                         "a dielectric needs ior > 1 (or an interior medium, whose boundary it then is)"), line


def test_ior_above_four_is_refused(tmp_path):
    out = tmp_path / "o.exr"
    line = one_error(render(yaml_scene(tmp_path, "{type: dielectric, ior: 4.5}"), out), out)
    assert not lacking(line, "materials.m.ior", "above 4"), line
