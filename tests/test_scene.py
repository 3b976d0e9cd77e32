"""Tests of mcpt.scene: the shipped scenes, every kind of bad input, overrides, transforms."""

from __future__ import annotations

import json
import math
import pickle
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from mcpt.scene import Scene, SceneError, Transform, load_scene, parse_scene

from .conftest import DATA

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"
REFERENCE = DATA / "scenes-ref"  # the canonical reference scenes the shipped ones copy

# A scene in the shipped scenes/ folder so that its relative mesh paths resolve; it is only
# parsed from text, never written. Every needle used by line_of() below is unique in BASE.
FAKE = SCENES / "test-input.yaml"
BASE = """\
# test scene
camera:
  position: [0.0, 0.0, 3.9]
  look_at: [0.0, 0.0, 0.0]
  up: [0.0, 1.0, 0.0]
  vfov_deg: 39.3077
  resolution: [256, 128]
render:
  spp: 16
  bounces: 4
  seed: 7
materials:
  white:
    albedo: [0.8, 0.7, 0.6]
  lamp:
    albedo: [0.0, 0.0, 0.0]
    emission: [10.0, 9.0, 8.0]
meshes:
  - file: cornell/white_walls.obj
    material: white
  - file: cornell/short_box.obj
    material: white
  - file: cornell/light.obj
    material: lamp
"""


def line_of(text: str, needle: str) -> int:
    """1-based line of the only line containing ``needle``."""
    hits = [i for i, line in enumerate(text.splitlines(), 1) if needle in line]
    assert len(hits) == 1, (needle, hits)
    return hits[0]


def edit(old: str, new: str, text: str = BASE) -> str:
    assert text.count(old) == 1, old
    return text.replace(old, new)


def assert_scene_error(text: str, line: int | None, key: str, *reason_parts: str, path: Path = FAKE) -> SceneError:
    """Parse ``text``; assert a SceneError ``<file>:<line>: <key>: ...`` mentioning ``reason_parts``."""
    with pytest.raises(SceneError) as info:
        parse_scene(text, path)
    msg = str(info.value)
    where = str(path) if line is None else f"{path}:{line}"
    prefix = f"{where}: {key}: " if key else f"{where}: "
    assert msg.startswith(prefix), msg
    assert "\n" not in msg
    for part in reason_parts:
        assert part in msg, (part, msg)
    assert info.value.line == line and info.value.key == key
    return info.value


# ---------------------------------------------------------------------------------------------
# Shipped scenes
# ---------------------------------------------------------------------------------------------


def _reference(name: str) -> dict:
    return json.loads((REFERENCE / name / "scene.json").read_text())


def test_cornell_box_matches_reference_json():
    ref = _reference("cornell")
    scene = load_scene(SCENES / "cornell-box.yaml")

    cam = scene.camera
    assert cam.position == tuple(ref["camera"]["position"])
    assert cam.look_at == tuple(ref["camera"]["look_at"])
    assert cam.up == tuple(ref["camera"]["up"])
    assert cam.vfov_deg == ref["camera"]["vfov_deg"]
    assert (cam.width, cam.height) == (ref["image"]["width"], ref["image"]["height"])
    assert scene.render.bounces == ref["integrator"]["bounces"]

    assert [m.file.name for m in scene.meshes] == [o["file"] for o in ref["objects"]]
    for mesh, obj in zip(scene.meshes, ref["objects"]):
        assert mesh.file.is_absolute() and mesh.file.is_file()
        # The shipped OBJ is a byte-exact copy of the reference one.
        assert mesh.file.read_bytes() == (REFERENCE / "cornell" / obj["file"]).read_bytes()
        material = scene.materials[mesh.material]
        assert material.type == "diffuse"
        assert material.albedo == tuple(obj["albedo"]), obj["file"]
        assert material.emission == tuple(obj["emission"]), obj["file"]
        np.testing.assert_array_equal(mesh.transform.matrix(), np.eye(4))


def test_furnace_matches_reference_json():
    ref = _reference("furnace")
    scene = load_scene(SCENES / "furnace.yaml")
    cam = scene.camera
    assert (cam.position, cam.look_at, cam.up) == ((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0))
    assert cam.vfov_deg == 60.0 and (cam.width, cam.height) == (64, 64)
    assert scene.render.bounces == ref["integrator"]["bounces"]
    (mesh,) = scene.meshes
    assert mesh.file == (SCENES / "furnace" / "sphere_inward.obj").resolve()
    assert mesh.file.read_bytes() == (REFERENCE / "furnace" / "sphere_inward.obj").read_bytes()
    material = scene.materials[mesh.material]
    assert material.albedo == (0.8, 0.8, 0.8) and material.emission == (1.0, 1.0, 1.0)


def test_base_scene_parses_with_defaults_and_absolute_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # relative mesh paths are relative to the YAML, not the cwd
    scene = parse_scene(BASE, FAKE)
    assert scene.source_path == FAKE
    assert (scene.camera.width, scene.camera.height) == (256, 128)
    assert (scene.render.spp, scene.render.bounces, scene.render.seed) == (16, 4, 7)
    assert scene.materials["white"].emission is None  # None = take Ke from the MTL, else 0
    assert scene.meshes[0].file == SCENES / "cornell" / "white_walls.obj"
    assert all(m.file.is_absolute() for m in scene.meshes)

    minimal = edit("render:\n  spp: 16\n  bounces: 4\n  seed: 7\n", "")
    render = parse_scene(minimal, FAKE).render
    assert (render.spp, render.bounces, render.seed) == (64, 8, 0)


def test_scene_is_immutable():
    scene = parse_scene(BASE, FAKE)
    with pytest.raises(ValidationError):
        scene.render.spp = 5  # type: ignore[misc]
    with pytest.raises(TypeError):
        scene.materials["new"] = scene.materials["white"]  # type: ignore[index]
    assert isinstance(scene.camera.position, tuple) and isinstance(scene.meshes, tuple)


# ---------------------------------------------------------------------------------------------
# Bad input: each gives one line "<file>:<line>: <key>: <reason>"
# ---------------------------------------------------------------------------------------------


def test_unknown_key():
    text = edit("  seed: 7", "  sede: 7")
    assert_scene_error(text, line_of(text, "sede"), "render.sede", "unknown key 'sede'", "did you mean 'seed'")


def test_unknown_key_in_list_item():
    text = edit("    material: lamp", "    material: lamp\n    colour: red")
    assert_scene_error(text, line_of(text, "colour"), "meshes.2.colour", "unknown key",
                       "allowed: file, shape, shape_index, flip_normals, material, transform")


def test_string_for_int():
    text = edit("spp: 16", "spp: abc")
    assert_scene_error(text, line_of(text, "spp"), "render.spp", "valid integer", "'abc'")


def test_quoted_number_is_not_a_number():
    text = edit("vfov_deg: 39.3077", 'vfov_deg: "39.3077"')
    assert_scene_error(text, line_of(text, "vfov_deg"), "camera.vfov_deg", "valid number", "str")


def test_bool_for_int():
    text = edit("bounces: 4", "bounces: true")
    assert_scene_error(text, line_of(text, "bounces"), "render.bounces", "valid integer", "bool")


def test_bool_for_float_in_list():
    text = edit("albedo: [0.8, 0.7, 0.6]", "albedo: [0.8, yes, 0.6]")
    assert_scene_error(text, line_of(text, "yes"), "materials.white.albedo.1", "valid number", "bool")


@pytest.mark.parametrize("bad", [".nan", ".inf", "-.inf"])
def test_nan_and_inf_rejected(bad):
    text = edit("vfov_deg: 39.3077", f"vfov_deg: {bad}")
    assert_scene_error(text, line_of(text, "vfov_deg"), "camera.vfov_deg", "finite number")


def test_inf_in_block_list_item_points_at_the_item():
    text = edit("position: [0.0, 0.0, 3.9]", "position:\n    - 0.0\n    - .inf\n    - 3.9")
    assert_scene_error(text, line_of(text, ".inf"), "camera.position.1", "finite number")


def test_duplicate_key_names_both_lines():
    text = edit("  seed: 7", "  seed: 7\n  spp: 32")
    first, second = [i for i, line in enumerate(text.splitlines(), 1) if "spp:" in line]
    assert_scene_error(text, second, "render.spp", "duplicate key 'spp'", f"line {first}")


def test_duplicate_key_inside_list_item():
    text = edit("    material: lamp", "    material: lamp\n    material: white")
    lines = [i for i, line in enumerate(text.splitlines(), 1) if "material:" in line]
    assert_scene_error(text, lines[-1], "meshes.2.material", "duplicate key", f"line {lines[-2]}")


def test_duplicate_top_level_section():
    text = BASE + "render:\n  spp: 1\n"
    first, second = [i for i, line in enumerate(text.splitlines(), 1) if line.startswith("render:")]
    assert_scene_error(text, second, "render", "duplicate key", f"line {first}")


def test_exponent_float_is_a_float_so_int_fields_reject_it():
    # YAML 1.2 reads 1e3 as a float (PyYAML's 1.1 rules would make it a string); spp is an int.
    text = edit("spp: 16", "spp: 1e3")
    assert_scene_error(text, line_of(text, "spp"), "render.spp", "valid integer", "float 1000.0", "write 1000")


def test_exponent_floats_load_as_floats():
    text = edit("vfov_deg: 39.3077", "vfov_deg: 4e1")
    text = edit("albedo: [0.8, 0.7, 0.6]", "albedo: [1E-5, +2e-1, 5.0e-1]", text)
    scene = parse_scene(text, FAKE)
    assert scene.camera.vfov_deg == 40.0 and isinstance(scene.camera.vfov_deg, float)
    assert scene.materials["white"].albedo == (1e-5, 0.2, 0.5)
    # Our resolver must not leak into PyYAML's own SafeLoader.
    assert yaml.safe_load("a: 1e3") == {"a": "1e3"}


def test_ints_stay_ints():
    text = edit("spp: 16", "spp: 1000")
    assert parse_scene(text, FAKE).render.spp == 1000


def test_missing_mesh_file():
    text = edit("cornell/light.obj", "cornell/nope.obj")
    resolved = (SCENES / "cornell" / "nope.obj").resolve()
    assert_scene_error(text, line_of(text, "nope.obj"), "meshes.2.file", "not found", str(resolved))


def test_mesh_file_is_a_directory():
    text = edit("file: cornell/light.obj", "file: cornell")
    line = text.splitlines().index("  - file: cornell") + 1
    assert_scene_error(text, line, "meshes.2.file", "not a regular file", str((SCENES / "cornell").resolve()))


def test_undefined_material_lists_defined_ones():
    text = edit("material: lamp", "material: lmap")
    assert_scene_error(text, line_of(text, "lmap"), "meshes.2.material", "undefined material 'lmap'", "lamp, white")


def test_malformed_yaml():
    text = edit("  bounces: 4", "  bounces: [4, 5")
    with pytest.raises(SceneError) as info:
        parse_scene(text, FAKE)
    msg = str(info.value)
    assert msg.startswith(f"{FAKE}:") and "malformed YAML" in msg, msg
    # The unclosed flow sequence is noticed on the next line; the message names both.
    assert info.value.line == line_of(text, "bounces") + 1
    assert f"started on line {line_of(text, 'bounces')}" in msg


def test_malformed_yaml_tab_indent():
    text = edit("  spp: 16", "\tspp: 16")
    assert_scene_error(text, line_of(text, "spp"), "", "malformed YAML")


def test_python_tags_refused():
    text = edit("spp: 16", "spp: !!python/object/apply:os.getcwd []")
    assert_scene_error(text, line_of(text, "spp"), "", "unsupported YAML")


@pytest.mark.parametrize("content", ["", "\n\n", "# only a comment\n"])
def test_empty_file(tmp_path, content):
    path = tmp_path / "empty.yaml"
    path.write_text(content)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}:1: ") and "empty" in str(info.value)


def test_top_level_not_a_mapping():
    text = "# a list\n- camera\n- meshes\n"
    assert_scene_error(text, 2, "", "must be a mapping", "list")


def test_unreadable_file(tmp_path):
    path = tmp_path / "missing.yaml"
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(f"{path}: cannot read scene file")


def test_negative_spp():
    text = edit("spp: 16", "spp: -3")
    assert_scene_error(text, line_of(text, "spp"), "render.spp", "greater than or equal to 1")


@pytest.mark.parametrize("res, index", [("[0, 128]", 0), ("[256, 0]", 1), ("[256, 16385]", 1)])
def test_resolution_bounds(res, index):
    text = edit("resolution: [256, 128]", f"resolution: {res}")
    assert_scene_error(text, line_of(text, "resolution"), f"camera.resolution.{index}", "Input should be")


def test_resolution_wrong_length():
    text = edit("resolution: [256, 128]", "resolution: [256]")
    assert_scene_error(text, line_of(text, "resolution"), "camera.resolution", "list of 2 integers", "1 item")


def test_missing_required_key_points_at_parent():
    text = edit("  vfov_deg: 39.3077\n", "")
    assert_scene_error(text, line_of(text, "camera:"), "camera.vfov_deg", "required key is missing")


def test_meshes_must_not_be_empty():
    text = BASE[: BASE.index("meshes:")] + "meshes: []\n"
    assert_scene_error(text, line_of(text, "meshes:"), "meshes", "at least 1 item")


@pytest.mark.parametrize("vfov", ["0", "180", "-5", "200.5"])
def test_vfov_bounds(vfov):
    text = edit("vfov_deg: 39.3077", f"vfov_deg: {vfov}")
    assert_scene_error(text, line_of(text, "vfov_deg"), "camera.vfov_deg", "Input should be")


def test_up_parallel_to_view_direction():
    text = edit("up: [0.0, 1.0, 0.0]", "up: [0.0, 0.0, 5.0]")
    assert_scene_error(text, line_of(text, "up:"), "camera.up", "parallel")


def test_position_equals_look_at():
    text = edit("position: [0.0, 0.0, 3.9]", "position: [0.0, 0.0, 0.0]")
    assert_scene_error(text, line_of(text, "look_at"), "camera.look_at", "equals position")


def test_albedo_out_of_range_and_negative_emission():
    text = edit("albedo: [0.8, 0.7, 0.6]", "albedo: [0.8, 1.5, 0.6]")
    assert_scene_error(text, line_of(text, "1.5"), "materials.white.albedo.1", "less than or equal to 1")
    text = edit("emission: [10.0, 9.0, 8.0]", "emission: [10.0, -9.0, 8.0]")
    assert_scene_error(text, line_of(text, "emission"), "materials.lamp.emission.1", "greater than or equal to 0")


def test_unknown_material_type():
    text = edit("  white:\n", "  white:\n    type: metal\n")
    assert_scene_error(text, line_of(text, "metal"), "materials.white.type", "'diffuse'")


def _with_transform(body: str) -> str:
    return edit("    material: lamp", "    material: lamp\n    transform:\n" + body)


@pytest.mark.parametrize("scale", ["0", "[1, 0, 1]", "0.0"])
def test_zero_scale(scale):
    text = _with_transform(f"      scale: {scale}")
    assert_scene_error(text, line_of(text, "scale"), "meshes.2.transform.scale", "nonzero")


def test_scale_wrong_type():
    text = _with_transform("      scale: big")
    assert_scene_error(text, line_of(text, "scale"), "meshes.2.transform.scale", "number or a list of 3 numbers")


def test_matrix_last_row_and_singular_and_exclusive():
    text = _with_transform("      matrix: [[1,0,0,0], [0,1,0,0], [0,0,1,0], [0,0,1,1]]")
    assert_scene_error(text, line_of(text, "matrix"), "meshes.2.transform.matrix.3", "last row")
    text = _with_transform("      matrix:\n        - [1,0,0,0]\n        - [0,1,0,0]\n"
                           "        - [1,1,0,0]\n        - [0,0,0,1]")
    assert_scene_error(text, line_of(text, "matrix"), "meshes.2.transform.matrix", "singular")
    text = _with_transform("      translate: [1, 2, 3]\n      matrix: [[1,0,0,0], [0,1,0,0], [0,0,1,0], [0,0,0,1]]")
    assert_scene_error(text, line_of(text, "matrix"), "meshes.2.transform.matrix", "cannot be combined with translate")


def test_scene_error_pickles():
    err = SceneError("a.yaml", 3, "render.spp", "bad")
    again = pickle.loads(pickle.dumps(err))
    assert str(again) == str(err) == "a.yaml:3: render.spp: bad"
    assert str(SceneError("a.yaml", None, "", "x\ny")) == "a.yaml: x y"


# ---------------------------------------------------------------------------------------------
# Overrides
# ---------------------------------------------------------------------------------------------


def test_with_overrides_replaces_and_keeps_the_rest():
    scene = parse_scene(BASE, FAKE)
    new = scene.with_overrides(spp=128, seed=3, resolution=(64, 32))
    assert (new.render.spp, new.render.bounces, new.render.seed) == (128, 4, 3)
    assert (new.camera.width, new.camera.height) == (64, 32)
    assert new.camera.vfov_deg == scene.camera.vfov_deg and new.meshes == scene.meshes
    assert new.source_path == FAKE
    # The original is untouched.
    assert (scene.render.spp, scene.camera.width) == (16, 256)
    assert scene.with_overrides(bounces=0).render.bounces == 0
    assert scene.with_overrides() == scene


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"spp": 0}, "render.spp"),
        ({"bounces": -1}, "render.bounces"),
        ({"seed": 2**63}, "render.seed"),
        ({"spp": True}, "render.spp"),
        ({"spp": 2.0}, "render.spp"),
        ({"resolution": (0, 10)}, "camera.resolution.0"),
        ({"resolution": (10, 20000)}, "camera.resolution.1"),
        ({"resolution": (10, 10, 10)}, "camera.resolution"),
    ],
)
def test_with_overrides_revalidates(kwargs, key):
    scene = parse_scene(BASE, FAKE)
    with pytest.raises(SceneError) as info:
        scene.with_overrides(**kwargs)
    assert str(info.value).startswith(f"{FAKE}: {key}: "), str(info.value)
    assert "override" in str(info.value)


# ---------------------------------------------------------------------------------------------
# Transforms
# ---------------------------------------------------------------------------------------------


def _transform(body: str) -> np.ndarray:
    scene = parse_scene(_with_transform(body), FAKE)
    return scene.meshes[2].transform.matrix()


def test_transform_identity_when_absent():
    m = parse_scene(BASE, FAKE).meshes[0].transform.matrix()
    assert m.dtype == np.float64 and m.shape == (4, 4)
    np.testing.assert_array_equal(m, np.eye(4))


def test_transform_composition_matches_hand_built_matrix():
    m = _transform("      translate: [1, -2, 3]\n      rotate_deg: [30, 45, 60]\n      scale: [2, 3, 4]")
    ax, ay, az = map(math.radians, (30, 45, 60))
    rx = np.array([[1, 0, 0, 0], [0, math.cos(ax), -math.sin(ax), 0], [0, math.sin(ax), math.cos(ax), 0], [0, 0, 0, 1]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay), 0], [0, 1, 0, 0], [-math.sin(ay), 0, math.cos(ay), 0], [0, 0, 0, 1]])
    rz = np.array([[math.cos(az), -math.sin(az), 0, 0], [math.sin(az), math.cos(az), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    s = np.diag([2.0, 3.0, 4.0, 1.0])
    t = np.eye(4)
    t[:3, 3] = [1, -2, 3]
    np.testing.assert_allclose(m, t @ rz @ ry @ rx @ s, atol=1e-12)


def test_rotation_order_is_x_then_y_then_z():
    m = _transform("      rotate_deg: [90, 90, 0]")
    # (0,1,0) --X 90--> (0,0,1) --Y 90--> (1,0,0); the other order would give (0,0,1).
    np.testing.assert_allclose(m @ [0, 1, 0, 1], [1, 0, 0, 1], atol=1e-12)
    m = _transform("      rotate_deg: [0, 0, 90]")
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [0, 1, 0, 1], atol=1e-12)  # counter-clockwise about +z


def test_uniform_scale_then_translate():
    m = _transform("      scale: 2\n      translate: [0, 0, 1]")
    np.testing.assert_allclose(m @ [1, 1, 1, 1], [2, 2, 3, 1])


def test_explicit_matrix_is_row_major_and_fresh():
    m = _transform("      matrix: [[1,0,0,5], [0,2,0,6], [0,0,3,7], [0,0,0,1]]")
    np.testing.assert_array_equal(m @ [1, 1, 1, 1], [6, 8, 10, 1])
    m[0, 0] = 99  # callers get their own array
    t = Transform.model_validate({"matrix": [[1, 0, 0, 5], [0, 2, 0, 6], [0, 0, 3, 7], [0, 0, 0, 1]]})
    assert t.matrix()[0, 0] == 1.0
    assert isinstance(parse_scene(BASE, FAKE), Scene)


def test_camera_basis_follows_convention():
    f, r, u = parse_scene(BASE, FAKE).camera.basis()
    np.testing.assert_allclose(f, [0, 0, -1])
    np.testing.assert_allclose(r, [1, 0, 0])  # red wall (x = -1) on the left
    np.testing.assert_allclose(u, [0, 1, 0])
