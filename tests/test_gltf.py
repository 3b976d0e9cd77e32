"""glTF 2.0 scenes (issue #19): accessors, node transforms, cameras, materials, refusals, pixels."""

from __future__ import annotations

import json
import logging
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from mcpt.output.image import read_exr
from mcpt.scene import SceneError, load_scene
from mcpt.scene.gltf import GltfError, accessors, nodes, open_gltf, scene_data
from mcpt.shapes.gltf_source import GltfPrimitive
from mcpt.shapes.mesh import MeshError, read_geometry
from tests.conftest import ROOT
from tests.gltf_files import QUAD, QUAD_FACES, GltfBuilder, write_obj

RX90 = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # rotation by +90 degrees about X


def small_scene() -> GltfBuilder:
    """A grey floor (parent/child TRS), a lamp (matrix), a rough metal quad, a camera at z = 4."""
    b = GltfBuilder()
    grey = b.material(name="grey", doubleSided=True,
                      pbrMetallicRoughness={"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0})
    lamp = b.material(name="lamp", emissiveFactor=[1, 1, 1],
                      pbrMetallicRoughness={"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
                      extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 5}})
    metal = b.material(name="metal", pbrMetallicRoughness={"baseColorFactor": [0.9, 0.6, 0.3, 1],
                                                           "metallicFactor": 1, "roughnessFactor": 0.5})
    cam = b.camera(math.radians(45), 1.0, name="main")
    b.node(camera=cam, translation=[0, 0, 4])
    floor = b.node(root=False, mesh=b.mesh(QUAD, QUAD_FACES, grey), scale=[2, 2, 2])
    b.node(translation=[0, 0, -1], children=[floor])
    m = np.eye(4)
    m[:3, :3] = np.asarray(RX90) * 0.5
    m[:3, 3] = [0, 1.5, 0]
    b.node(mesh=b.mesh(QUAD, QUAD_FACES, lamp), matrix=m.T.reshape(-1).tolist())
    b.node(mesh=b.mesh(QUAD, QUAD_FACES, metal), translation=[0.3, -0.3, -0.5], scale=[0.4, 0.4, 0.4])
    return b


# --- accessors ---------------------------------------------------------------------------------

@pytest.mark.parametrize("dtype", ["int8", "uint8", "int16", "uint16", "uint32", "float32"])
def test_each_component_type_reads_its_values(tmp_path, dtype):
    values = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 100]], dtype)
    b = GltfBuilder()
    i = b.accessor(values)
    g = open_gltf(b.write_gltf(tmp_path / f"{dtype}.gltf"))
    out = accessors.read(g, i)
    assert out.shape == (3, 3)
    np.testing.assert_array_equal(out, values)


def test_interleaved_stride_and_offset(tmp_path):
    # Two VEC3 float attributes interleaved with a 4-byte pad: stride 28 bytes.
    rows = np.arange(4 * 7, dtype=np.float32).reshape(4, 7)
    b = GltfBuilder()
    view = b.view(rows.tobytes(), stride=28)
    first = b.accessor(rows[:, :3], view=view, offset=0)
    second = b.accessor(rows[:, 3:6], view=view, offset=12)
    g = open_gltf(b.write_gltf(tmp_path / "s.gltf"))
    np.testing.assert_array_equal(accessors.read(g, first), rows[:, :3])
    np.testing.assert_array_equal(accessors.read(g, second), rows[:, 3:6])


def test_normalized_integers_map_to_unit_range(tmp_path):
    b = GltfBuilder()
    u8 = b.accessor(np.array([[0, 255], [51, 255]], np.uint8), normalized=True)
    i8 = b.accessor(np.array([[-128, -127], [127, 0]], np.int8), normalized=True)
    u16 = b.accessor(np.array([[0, 65535]], np.uint16), normalized=True)
    g = open_gltf(b.write_gltf(tmp_path / "n.gltf"))
    np.testing.assert_allclose(accessors.read(g, u8), [[0, 1], [0.2, 1]])
    np.testing.assert_allclose(accessors.read(g, i8), [[-1, -1], [1, 0]])  # -128 clamps to -1
    np.testing.assert_allclose(accessors.read(g, u16), [[0, 1]])


# --- transforms and cameras -------------------------------------------------------------------

def test_trs_is_t_r_s_and_children_compose_parent_times_child(tmp_path):
    b = GltfBuilder()
    s45 = math.sin(math.pi / 4)
    child_m = np.eye(4)
    child_m[:3, 3] = [1, 0, 0]
    child = b.node(root=False, matrix=child_m.T.reshape(-1).tolist())
    b.node(translation=[0, 2, 0], rotation=[0, s45, 0, s45], scale=[3, 3, 3], children=[child])
    placed = dict(nodes.instances(open_gltf(b.write_gltf(tmp_path / "t.gltf"))))
    ry = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]], float)  # Ry(+90)
    t = np.eye(4)
    t[:3, 3] = [0, 2, 0]
    parent = t @ ry @ np.diag([3.0, 3.0, 3.0, 1.0])
    np.testing.assert_allclose(placed[1], parent, atol=1e-12)
    np.testing.assert_allclose(placed[0], parent @ child_m, atol=1e-12)
    # The child's origin: (1, 0, 0) scaled to (3, 0, 0), turned to (0, 0, -3), lifted to (0, 2, -3).
    np.testing.assert_allclose(placed[0] @ [0, 0, 0, 1], [0, 2, -3, 1], atol=1e-12)


def test_camera_looks_down_its_minus_z_at_a_known_point(tmp_path):
    b = GltfBuilder()
    s45 = math.sin(math.pi / 4)
    b.node(mesh=b.mesh(QUAD, QUAD_FACES))
    cam = b.camera(math.radians(30), 1.5)
    # Turned +90 degrees about Y, -Z points along -X: from (3, 0, 0) it looks at the origin.
    b.node(translation=[3, 0, 0], rotation=[0, s45, 0, s45], camera=cam)
    data = scene_data(b.write_gltf(tmp_path / "c.gltf"))
    c = data["camera"]
    np.testing.assert_allclose(c["position"], [3, 0, 0], atol=1e-12)
    direction = np.subtract(c["look_at"], c["position"])
    np.testing.assert_allclose(direction / np.linalg.norm(direction), [-1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(c["up"], [0, 1, 0], atol=1e-12)
    assert c["vfov_deg"] == pytest.approx(30) and c["resolution"] == [768, 512]


def test_camera_by_name_and_unknown_name(tmp_path):
    b = small_scene()
    second = b.camera(math.radians(20), name="close")
    b.node(camera=second, translation=[0, 0, 2])
    path = b.write_gltf(tmp_path / "s.gltf")
    assert load_scene(path).camera.position == (0, 0, 4)
    scene = load_scene(path, overrides=("camera=close",))
    assert scene.camera.position == (0, 0, 2) and scene.camera.vfov_deg == pytest.approx(20)
    assert load_scene(path, overrides=("camera=1",)).camera.position == (0, 0, 2)  # cameras[1]
    with pytest.raises(GltfError, match=r"s.gltf: cameras: camera 'nope': no such camera or camera node "
                                        r"\(cameras: 'main', 'close'\)"):
        load_scene(path, overrides=("camera=nope",))


# --- materials --------------------------------------------------------------------------------

def test_metal_rough_mapping(tmp_path, caplog):
    b = small_scene()
    b.doc["materials"].append({"name": "shiny", "alphaMode": "MASK", "occlusionTexture": {"index": 0},
                               "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1],
                                                        "metallicFactor": 0, "roughnessFactor": 0.3}})
    b.node(mesh=b.mesh(QUAD, QUAD_FACES, 3), translation=[0, 0, -3])
    b.node(mesh=b.mesh(QUAD, QUAD_FACES), translation=[0, 0, -4])  # no material: the default
    with caplog.at_level(logging.WARNING, logger="mcpt"):
        scene = load_scene(b.write_gltf(tmp_path / "m.gltf"))
    mats = scene.materials
    grey = mats["grey"]  # every material is the spec's own metal-rough BRDF (metalrough)
    assert (grey.type, grey.albedo, grey.metallic, grey.roughness) == ("metalrough", (0.5, 0.5, 0.5), 0, 1)
    assert grey.two_sided
    assert mats["lamp"].emission == (5, 5, 5) and not mats["lamp"].two_sided
    metal = mats["metal"]  # roughness stays perceptual: metalrough squares it (alpha 0.25)
    assert (metal.type, metal.albedo, metal.metallic, metal.roughness) == ("metalrough", (0.9, 0.6, 0.3), 1, 0.5)
    shiny = mats["shiny"]
    assert (shiny.type, shiny.albedo, shiny.metallic, shiny.roughness) == ("metalrough", (0.2, 0.4, 0.6), 0, 0.3)
    default = mats["gltf_default"]  # spec 3.9.6: white, metallic 1, roughness 1
    assert (default.type, default.albedo, default.metallic, default.roughness) == ("metalrough", (1, 1, 1), 1, 1)
    text = caplog.text
    assert "approximated" not in text and "rounded" not in text
    assert re.search(r"materials\[3\] 'shiny': ignored by mcpt: occlusionTexture", text)
    assert mats["shiny"].opacity_cutoff == 0.5 and mats["shiny"].opacity.color0 == (1.0, 1.0, 1.0)
    assert [m.material for m in scene.meshes] == ["grey", "lamp", "metal", "shiny", "gltf_default"]


def test_given_vertex_normals_shade_smooth_and_are_read(tmp_path):
    b = small_scene()
    normals = np.array([[0, 0, 1], [0, 0.6, 0.8], [0, 0, 1], [0, 0, 1]], np.float32)
    b.node(mesh=b.mesh(QUAD, QUAD_FACES, 0, normals=normals), translation=[0, 0, -3])
    path = b.write_gltf(tmp_path / "n.gltf")
    scene = load_scene(path)
    assert not scene.materials["grey"].smooth_normals and scene.materials["grey_2"].smooth_normals
    assert scene.meshes[-1].material == "grey_2" and scene.meshes[-1].shape_index == 3
    raw = read_geometry(GltfPrimitive(path, 3), need_normals=True)
    np.testing.assert_allclose(raw.parts[0].normals, normals)
    assert read_geometry(GltfPrimitive(path, 0)).parts[0].normals is None


def test_embedded_base_colour_texture_goes_to_the_cache(tmp_path, monkeypatch):
    import cv2

    monkeypatch.setenv("MCPT_CACHE_DIR", str(tmp_path / "cache"))
    ok, png = cv2.imencode(".png", np.full((2, 2, 3), 200, np.uint8))
    b = small_scene()
    b.doc["images"] = [{"bufferView": b.view(png.tobytes()), "mimeType": "image/png"}]
    b.doc["samplers"] = [{"wrapS": 33071, "wrapT": 33071, "magFilter": 9728}]
    b.doc["textures"] = [{"source": 0, "sampler": 0}]
    b.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    b.doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = [1, 1, 1, 1]
    scene = load_scene(b.write_glb(tmp_path / "t.glb"))
    tex = scene.materials["grey"].albedo_texture
    assert tex.file.parent == tmp_path / "cache" / "gltf-images" and tex.file.read_bytes() == png.tobytes()
    assert tex.wrap == "clamp" and tex.filter == "nearest"
    b.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0, "texCoord": 1}
    with pytest.raises(GltfError, match=r"materials\[0\] 'grey': baseColorTexture.texCoord 1: mcpt reads "
                                        "TEXCOORD_0 only"):
        load_scene(b.write_glb(tmp_path / "t.glb"))


# --- refusals ---------------------------------------------------------------------------------

def _one_line(exc) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_accessor_longer_than_its_view_is_one_located_line(tmp_path):
    b = small_scene()
    b.doc["accessors"][2]["count"] = 1000
    with pytest.raises(GltfError) as exc:
        load_scene(b.write_gltf(tmp_path / "model.gltf"))
    assert re.fullmatch(r".*model.gltf: accessors\[2\]: 1000 elements of 12 bytes \(stride 12\) from byteOffset 0 "
                        r"need 12000 bytes, but bufferViews\[2\] has byteLength 48", _one_line(exc))


def test_buffer_shorter_than_declared(tmp_path):
    b = small_scene()
    path = b.write_gltf(tmp_path / "model.gltf", external=True)
    (tmp_path / "model.bin").write_bytes((tmp_path / "model.bin").read_bytes()[:10])
    with pytest.raises(GltfError, match=r"model.gltf: buffers\[0\]: byteLength \d+ but the data holds only 10 bytes"):
        load_scene(path)
    (tmp_path / "model.bin").unlink()
    with pytest.raises(GltfError, match=r"model.gltf: buffers\[0\]: cannot read .*model.bin"):
        load_scene(path)


def test_bad_index_non_triangles_sparse_lights_missing_file(tmp_path):
    b = small_scene()
    b.blob[b.doc["bufferViews"][1]["byteOffset"]] = 9  # first index of the floor: vertex 9 of 4
    path = b.write_gltf(tmp_path / "m.gltf")
    with pytest.raises(MeshError, match=r"m.gltf: meshes\[0\].primitives\[0\].indices: accessors\[1\]: "
                                        r"index 9 at 0 is out of range \(4 vertices\)"):
        read_geometry(GltfPrimitive(path, 0))
    b = small_scene()
    b.doc["meshes"][1]["primitives"][0]["mode"] = 1
    with pytest.raises(GltfError, match=r"meshes\[1\].primitives\[0\]: mode 1 \(LINES\): mcpt renders "
                                        r"triangles only \(mode 4\)"):
        load_scene(b.write_gltf(tmp_path / "m.gltf"))
    b = small_scene()
    b.doc["accessors"][0]["sparse"] = {"count": 1}
    with pytest.raises(GltfError, match=r"accessors\[0\]: sparse accessors are not supported"):
        load_scene(b.write_gltf(tmp_path / "m.gltf"))
    b = small_scene()
    b.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "name": "bulb"}]}}
    b.node(extensions={"KHR_lights_punctual": {"light": 1}})  # issue #20: lights are read
    with pytest.raises(GltfError, match=r"nodes\[5\]: KHR_lights_punctual light 1 does not exist \(1 lights\)"):
        load_scene(b.write_gltf(tmp_path / "m.gltf"))
    with pytest.raises(SceneError, match=r"missing.glb: cannot read the glTF file: No such file"):
        load_scene(tmp_path / "missing.glb")


def test_malformed_json_deep_nesting_and_node_cycles_are_one_line(tmp_path):
    bad = tmp_path / "bad.gltf"
    bad.write_text('{"asset": {"version": "2.0"},\n "nodes": [,]}')
    with pytest.raises(GltfError, match=r"bad.gltf:2: malformed JSON: Expecting value"):
        load_scene(bad)
    bad.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(GltfError, match=r"bad.gltf: malformed JSON: nested too deeply"):
        load_scene(bad)
    b = small_scene()
    b.doc["nodes"][1]["children"] = [2]  # floor -> its own parent
    with pytest.raises(GltfError, match=r"nodes\[2\]: reached twice: the node hierarchy must be a tree"):
        load_scene(b.write_glb(tmp_path / "c.glb"))


def test_cli_refusal_exits_2_with_one_line_and_writes_nothing(tmp_path):
    b = small_scene()
    b.doc["accessors"][2]["count"] = 1000
    path = b.write_glb(tmp_path / "model.glb")
    out = tmp_path / "o.exr"
    res = subprocess.run([sys.executable, "-m", "mcpt", "render", str(path), "-o", str(out)],
                         capture_output=True, text=True)
    assert res.returncode == 2
    assert re.fullmatch(r"mcpt: error: \S*model.glb: accessors\[2\]: .*byteLength 48\n", res.stderr), res.stderr
    assert not out.exists()



def test_cli_camera_option_picks_the_named_camera_and_is_refused_elsewhere(tmp_path):
    b = small_scene()
    b.node(camera=b.camera(math.radians(20), name="close"), translation=[0, 0, 2])
    path = b.write_gltf(tmp_path / "s.gltf")
    cmd = [sys.executable, "-m", "mcpt", "render", "--spp", "1", "--resolution", "8x8", "--json", "--quiet"]
    views = {}
    for how in (["--camera", "close"], ["-D", "camera=close"], []):
        out = tmp_path / f"{len(views)}.exr"
        res = subprocess.run([*cmd, str(path), *how, "-o", str(out)], capture_output=True, text=True)
        assert res.returncode == 0, res.stderr
        views[" ".join(how)] = read_exr(out)[0]
    assert np.array_equal(views["--camera close"], views["-D camera=close"])
    assert not np.array_equal(views["--camera close"], views[""])  # not the first camera's view
    yaml_scene = ROOT / "scenes" / "cornell-box.yaml"
    res = subprocess.run([*cmd, str(yaml_scene), "--camera", "close", "-o", str(tmp_path / "y.exr")],
                         capture_output=True, text=True)
    assert res.returncode == 2 and "--camera" in res.stderr and not (tmp_path / "y.exr").exists()

# --- a YAML scene placing the whole file -------------------------------------------------------

def test_yaml_places_the_whole_file_with_its_own_materials(tmp_path):
    from mcpt.shapes.world import load_world

    b = small_scene()
    b.doc["materials"][2]["pbrMetallicRoughness"]["metallicFactor"] = 0  # diffuse only
    gltf = b.write_glb(tmp_path / "s.glb")
    raw = read_geometry(gltf)
    assert [m.name for m in raw.materials] == ["grey", "lamp", "metal"]
    assert raw.materials[1].ke == (5, 5, 5) and raw.materials[0].kd == (0.5, 0.5, 0.5)
    np.testing.assert_allclose(raw.parts[0].vertices[0], [-2, -2, -1])  # the node transforms applied
    (tmp_path / "s.yaml").write_text(json.dumps({
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 3], "vfov_deg": 45, "resolution": [16, 16]},
        "meshes": [{"file": "s.glb"}]}))
    a, d = load_world(load_scene(tmp_path / "s.yaml")), load_world(load_scene(gltf))
    assert a.n_triangles == d.n_triangles == 6
    np.testing.assert_array_equal(np.sort(a.materials.emission, axis=0), np.sort(d.materials.emission, axis=0))
    assert a.lights.count == d.lights.count == 2


# --- pixels ------------------------------------------------------------------------------------

def test_glb_and_gltf_render_the_same_pixels(gl, tmp_path):
    from mcpt.api import render_scene

    b = small_scene()
    settings = {"seed": 3, "spp": 8, "bounces": 3, "resolution": (16, 16)}
    ra, _ = render_scene(b.write_glb(tmp_path / "s.glb"), **settings)
    rb, _ = render_scene(b.write_gltf(tmp_path / "s.gltf", external=True), **settings)
    assert ra.image.mean() > 0.01
    np.testing.assert_array_equal(ra.image, rb.image)


def test_gltf_and_equivalent_yaml_render_the_same_pixels(gl, tmp_path):
    from mcpt.api import render_scene

    write_obj(tmp_path / "quad.obj", QUAD, QUAD_FACES)
    lamp = [[*r, t] for r, t in zip(np.asarray(RX90) * 0.5, [0, 1.5, 0])] + [[0, 0, 0, 1]]
    (tmp_path / "s.yaml").write_text(json.dumps({
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 3], "up": [0, 1, 0], "vfov_deg": 45,
                   "resolution": [16, 16]},
        "materials": {"grey": {"type": "metalrough", "albedo": [0.5, 0.5, 0.5], "metallic": 0, "roughness": 1,
                               "two_sided": True},
                      "lamp": {"type": "metalrough", "albedo": [0, 0, 0], "metallic": 0, "emission": [5, 5, 5],
                               "two_sided": False},
                      "metal": {"type": "metalrough", "albedo": [0.9, 0.6, 0.3], "metallic": 1, "roughness": 0.5,
                                "two_sided": False}},
        "meshes": [{"file": "quad.obj", "material": "grey", "transform": {"translate": [0, 0, -1], "scale": 2}},
                   {"file": "quad.obj", "material": "lamp", "transform": {"matrix": lamp}},
                   {"file": "quad.obj", "material": "metal",
                    "transform": {"translate": [0.3, -0.3, -0.5], "scale": 0.4}}]}))
    settings = {"seed": 3, "spp": 8, "bounces": 3, "resolution": (16, 16)}
    ra, _ = render_scene(small_scene().write_glb(tmp_path / "s.glb"), **settings)
    rb, _ = render_scene(tmp_path / "s.yaml", **settings)
    assert ra.image.mean() > 0.01
    np.testing.assert_allclose(ra.image, rb.image, rtol=1e-5, atol=1e-6)


def test_emissive_texture_is_an_emission_texture_scaled_by_factor_and_strength(tmp_path, monkeypatch):
    """Issue #22: emissiveTexture -> emission_texture, emissiveFactor x emissiveStrength its scale."""
    import cv2

    monkeypatch.setenv("MCPT_CACHE_DIR", str(tmp_path / "cache"))
    ok, png = cv2.imencode(".png", np.full((2, 2, 3), 90, np.uint8))
    b = small_scene()
    b.doc["images"] = [{"bufferView": b.view(png.tobytes()), "mimeType": "image/png"}]
    b.doc["textures"] = [{"source": 0}]
    b.doc["materials"][1]["emissiveTexture"] = {"index": 0}
    b.doc["materials"][1]["emissiveFactor"] = [1, 0.5, 0.25]
    lamp = load_scene(b.write_glb(tmp_path / "t.glb")).materials["lamp"]
    assert lamp.emission == (5, 2.5, 1.25)
    assert lamp.emission_texture.file.read_bytes() == png.tobytes()
