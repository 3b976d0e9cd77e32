"""Reader features that published Mitsuba 3 scenes rely on (issue #19, checked against
mitsuba-renderer/mitsuba-data's documentation scenes): ``<path>`` search folders, and objects
declared at the top level with an ``id`` and placed by ``<ref>``. Small hand-made files only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcpt.scene import SceneError
from mcpt.scene.mitsuba import scene_data

CAMERA = Path(__file__).parent / "data" / "mitsuba" / "camera.xml"
SQUARE = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n"


def scene(path: Path, body: str, camera: bool = True) -> Path:
    inc = f'<include filename="{CAMERA}"/>' if camera else ""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'<scene version="3.0.0">\n{inc}\n{body}\n</scene>\n')
    return path


def test_path_folder_finds_meshes_and_includes_as_mitsuba_does(tmp_path):
    # The layout of Mitsuba's documentation scenes: docs/scenes/X.xml names a shared folder with
    # <path value=...> and includes include/Y.xml, whose meshes/Z are in that shared folder.
    lib = tmp_path / "scenes" / "lib" / "common"
    (lib / "meshes").mkdir(parents=True)
    (lib / "meshes" / "quad.obj").write_text(SQUARE)
    scene(tmp_path / "scenes" / "include" / "part.xml",
          '<shape type="obj"><string name="filename" value="meshes/quad.obj"/></shape>', camera=False)
    top = scene(tmp_path / "scenes" / "top.xml",
                '<path value="lib/common"/>\n<include filename="include/part.xml"/>')
    data, _ = scene_data(top)
    assert [Path(m["file"]) for m in data["meshes"]] == [(lib / "meshes" / "quad.obj").resolve()]


def test_a_path_folder_is_searched_before_the_scene_folder(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "quad.obj").write_text(SQUARE)
    (tmp_path / "quad.obj").write_text(SQUARE)
    top = scene(tmp_path / "top.xml", '<path value="lib"/>\n'
                '<shape type="obj"><string name="filename" value="quad.obj"/></shape>')
    data, _ = scene_data(top)
    assert Path(data["meshes"][0]["file"]) == (tmp_path / "lib" / "quad.obj").resolve()


def test_a_missing_path_folder_is_one_located_line(tmp_path):
    top = scene(tmp_path / "top.xml", '\n<path value="nowhere"/>')
    with pytest.raises(SceneError, match=r'top.xml:4: <path>: folder not found: .*nowhere$'):
        scene_data(top)


def test_path_only_at_the_top_level(tmp_path):
    top = scene(tmp_path / "top.xml", '<shape type="sphere"><path value="."/></shape>')
    with pytest.raises(SceneError, match=r"top.xml:3: <path>: <path> can only be a child of <scene>"):
        scene_data(top)


def test_an_area_emitter_declared_at_the_top_and_referenced_by_a_shape(tmp_path):
    # Mitsuba's scenes/cbox/cbox-rgb.xml: <emitter type="area" id="light"> at the top level,
    # <ref id="light"/> inside the luminaire.
    top = scene(tmp_path / "top.xml",
                '<emitter type="area" id="light"><rgb name="radiance" value="4, 5, 6"/></emitter>\n'
                '<shape type="sphere"><ref id="light"/></shape>\n<shape type="sphere"/>')
    data, _ = scene_data(top)
    emissions = [data["materials"][m["material"]].get("emission") for m in data["meshes"]]
    assert emissions == [[4.0, 5.0, 6.0], None]
    assert "lights" not in data


def test_an_unreferenced_top_level_area_emitter_is_still_refused(tmp_path):
    top = scene(tmp_path / "top.xml",
                '<emitter type="area" id="light"><rgb name="radiance" value="4"/></emitter>\n'
                '<shape type="sphere"/>')
    with pytest.raises(SceneError, match=r'top.xml:3: <emitter type="area" id="light">: not supported'):
        scene_data(top)


def test_a_sampler_declared_at_the_top_and_referenced_by_the_sensor(tmp_path):
    # Mitsuba's docs/scenes/sampler_*.xml declare <sampler id="my_sampler"> before the sensor.
    top = scene(tmp_path / "top.xml",
                '<sampler type="independent" id="smp"><integer name="sample_count" value="7"/></sampler>\n'
                '<sensor type="perspective"><ref id="smp"/><film type="hdrfilm">'
                '<integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>\n'
                '<shape type="sphere"/>', camera=False)
    data, _ = scene_data(top)
    assert data["render"]["spp"] == 7


def test_rotate_uses_the_axis_unnormalised_as_mitsuba_does(tmp_path):
    # Mitsuba 3.9.1: ScalarTransform4f().rotate([0, 0, 2], 90) @ (1, 0, 0) = (0, 2, 0), and
    # rotate([1, 1, 1], 120) @ (1, 0, 0) = (1, 2.36603, 0.633975); its hello.xml rotates about (0, 1, 1).
    from mcpt.scene.mitsuba.values import transform
    from mcpt.scene.mitsuba.xmltree import read_tree

    def moved(op: str) -> np.ndarray:
        path = tmp_path / "t.xml"
        path.write_text(f'<scene version="3.0.0"><transform name="t">{op}</transform></scene>')
        return transform(read_tree(path).root.children[0]) @ [1.0, 0.0, 0.0, 1.0]

    np.testing.assert_allclose(moved('<rotate z="2" angle="90"/>'), [0, 2, 0, 1], atol=1e-12)
    np.testing.assert_allclose(moved('<rotate x="1" y="1" z="1" angle="120"/>'),
                               [1, 2.36603, 0.633975, 1], atol=1e-5)


def test_generated_vertex_normals_are_angle_weighted_as_mitsubas(tmp_path):
    # A file without normals shades with Mitsuba's generated ones (src/render/mesh.cpp,
    # recompute_normals: unit face normals weighted by the corner angle). Vertex 1 (the origin)
    # has a 90-degree corner in the z = 0 face (normal +z) and a 45-degree corner in the x = 0 face
    # (normal +x): its normal is (45, 0, 90) normalised, where an unweighted mean gives (1, 0, 1).
    from mcpt.shapes.mesh import load_mesh

    obj = tmp_path / "fold.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 1 1\nf 1 2 3\nf 1 3 4\n")
    mesh = load_mesh(obj, need_normals=True)
    at_origin = np.flatnonzero(np.all(mesh.vertices == 0.0, axis=1))
    assert at_origin.size == 1
    expected = np.array([45.0, 0.0, 90.0]) / np.hypot(45.0, 90.0)
    np.testing.assert_allclose(mesh.normals[at_origin[0]], expected, atol=1e-6)


@pytest.mark.parametrize("value, want", [("1", 1.0), ("1, 1, 1", 1.0), ("0.5", 0.5)])
def test_specular_reflectance_is_mapped(tmp_path, value, want):
    # Veach's MIS scene (mitsuba-data docs/scenes/include/veach_mis.xml) writes
    # <rgb name="specular_reflectance" value="1"/> on its (rough) plastic plates: Mitsuba's default.
    # Other values were refused; issue #22 maps them (mcpt/shading/specular_weights.py).
    top = scene(tmp_path / "top.xml",
                '<shape type="sphere"><bsdf type="plastic">'
                f'<rgb name="specular_reflectance" value="{value}"/></bsdf></shape>')
    data, _ = scene_data(top)
    assert [m["type"] for m in data["materials"].values()] == ["plastic"]
    assert [m["specular_reflectance"] for m in data["materials"].values()] == [[want] * 3]


def test_conductor_presets_are_mitsubas_rgb_values(tmp_path):
    # Mitsuba 3.9.1 scalar_rgb, mi.traverse(load_dict({"type": "conductor", "material": "Au"})):
    # eta (0.143036, 0.375307, 1.44205), k (3.983, 2.38556, 1.60336); a-C is a preset there too.
    top = scene(tmp_path / "top.xml",
                '<shape type="sphere"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>\n'
                '<shape type="sphere"><bsdf type="conductor"><string name="material" value="a-C"/></bsdf></shape>')
    data, _ = scene_data(top)
    gold, carbon = (data["materials"][m["material"]] for m in data["meshes"])
    assert gold["fresnel"] == "conductor" and carbon["fresnel"] == "conductor"
    np.testing.assert_allclose(gold["eta"], [0.143036, 0.375307, 1.44205])
    np.testing.assert_allclose(gold["k"], [3.983, 2.38556, 1.60336])
    with pytest.raises(SceneError, match="'unobtainium' is not among Mitsuba 3's presets"):
        scene_data(scene(tmp_path / "bad.xml", '<shape type="sphere"><bsdf type="conductor">'
                         '<string name="material" value="unobtainium"/></bsdf></shape>'))
