"""Issue #19 / #24, absurd sizes: a scene with more triangles than mcpt can hold is refused in one
located line, exit 2, nothing written, before any geometry is built (mcpt/gpu/scene_size.py);
the triangle counts it reads (mcpt/shapes/counts.py) agree with what the loaders build."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcpt.gpu import host_memory, limits
from mcpt.gpu.scene_size import SceneTooLarge, check_scene_size, triangle_limit
from mcpt.scene import load_scene
from mcpt.shapes import counts
from mcpt.shapes import primitives as P
from mcpt.shapes.bvh import SAH_MAX_TRIANGLES
from mcpt.shapes.bvh_build import build_bvh
from mcpt.shapes.mesh import load_mesh

from .gltf_files import QUAD, QUAD_FACES, GltfBuilder
from .test_cli import assert_fails_cleanly, invoke
from .test_mitsuba import serialized_file, serialized_shape

SPHERE = P.triangle_count("sphere")
CAMERA_XML = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
              '<integer name="height" value="8"/></film></sensor>')
YAML_HEAD = """\
camera:
  position: [0, 0, 10]
  look_at: [0, 0, 0]
  up: [0, 1, 0]
  vfov_deg: 40
  resolution: [8, 8]
render:
  spp: 1
  bounces: 1
materials:
  m:
    albedo: [0.5, 0.5, 0.5]
    emission: [1, 1, 1]
meshes:
"""


@pytest.fixture
def plenty(monkeypatch):
    """A host with memory to spare, so that the GL buffers' limit is the one met."""
    monkeypatch.setattr(host_memory, "available_bytes", lambda: 1 << 50)


def instances_xml(folder: Path, n: int) -> Path:
    """The issue's repro: one sphere in a shapegroup, instanced ``n`` times (line 4 on)."""
    lines = ['<scene version="3.0.0">', CAMERA_XML, '<shape type="shapegroup" id="g"><shape type="sphere"/></shape>']
    lines += [f'<shape type="instance"><ref id="g"/><transform name="to_world"><translate x="{i}"/></transform>'
              '</shape>' for i in range(n)]
    path = folder / "many.xml"
    path.write_text("\n".join(lines + ["</scene>"]) + "\n")
    return path


def yaml_scene(folder: Path, entries: list[str]) -> Path:
    path = folder / "scene.yaml"
    path.write_text(YAML_HEAD + "".join(f"  - {{{e}, material: m}}\n" for e in entries))
    return path


# ---- the refusal, through the command line -----------------------------------------------------

def test_repro_instances_refused_in_one_line(tmp_path, monkeypatch, plenty):
    """900 instances of a 32 760-triangle sphere (29.5 M triangles, past the 26.6 M the GL buffers
    hold): the issue's 3000-instance repro ran 116 s and was OOM-killed at 24 GB."""
    monkeypatch.chdir(tmp_path)
    instances_xml(tmp_path, 900)
    crossing = limits.MAX_TRIANGLES // SPHERE  # 0-based index of the instance that crosses
    line = assert_fails_cleanly(invoke("many.xml", "--spp", "1", "-o", "out.exr"), tmp_path,
                                f"many.xml:{4 + crossing}: <shape type=\"instance\">",
                                f"{900 * SPHERE:,}".replace(",", " "), "900 x sphere of 32 760",
                                f"at most {limits.MAX_TRIANGLES:,}".replace(",", " "), "GL buffer limit")
    assert "Traceback" not in line


def test_yaml_sphere_entries_refused_at_the_crossing_entry(tmp_path, monkeypatch, plenty):
    monkeypatch.chdir(tmp_path)
    yaml_scene(tmp_path, ["shape: sphere"] * 900)
    crossing = limits.MAX_TRIANGLES // SPHERE
    assert_fails_cleanly(invoke("scene.yaml", "-o", "out.exr"), tmp_path,
                         f"scene.yaml:{15 + crossing}: meshes.{crossing}:", "900 x sphere of 32 760")


def test_yaml_entries_naming_a_big_mesh_refused_from_its_header(tmp_path, monkeypatch, plenty):
    """Thousands of entries naming one mesh file: its count is read once (here a PLY header that
    announces 10^6 faces; the file is never read further) and multiplied."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "big.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                       b"property float x\nproperty float y\nproperty float z\n"
                                       b"element face 1000000\nproperty list uchar int vertex_indices\n"
                                       b"end_header\n")
    (tmp_path / "floor.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    yaml_scene(tmp_path, ["file: floor.obj"] + ["file: big.ply"] * 3000)
    assert_fails_cleanly(invoke("scene.yaml", "-o", "out.exr"), tmp_path,
                         "scene.yaml:42: meshes.27:", "3000 x big.ply of 1 000 000", "floor.obj: 1")


def test_a_small_limit_refuses_what_rendered_before(tmp_path, monkeypatch, plenty):
    """The fix's own check, scaled: with room for two spheres, the third is refused (the old code
    rendered it); exactly the scene's count is not refused and renders."""
    monkeypatch.chdir(tmp_path)
    instances_xml(tmp_path, 3)
    monkeypatch.setattr(limits, "MAX_TRIANGLES", 3 * SPHERE - 1)
    assert_fails_cleanly(invoke("many.xml", "-o", "out.exr"), tmp_path,
                         "many.xml:6: <shape type=\"instance\">", "3 x sphere of 32 760")
    monkeypatch.setattr(limits, "MAX_TRIANGLES", 3 * SPHERE)
    result = invoke("many.xml", "--spp", "1", "-o", "out.exr")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out.exr").stat().st_size > 0


def test_memory_limit(tmp_path, monkeypatch):
    """Where the host holds fewer triangles than the GL buffers, its memory is the limit quoted."""
    free = host_memory.host_bytes(8, 8, 1) + 10 * SPHERE * host_memory.BYTES_PER_TRIANGLE
    monkeypatch.setattr(host_memory, "available_bytes", lambda: free)
    assert triangle_limit(8, 8)[0] == 10 * SPHERE
    scene = load_scene(yaml_scene(tmp_path, ["shape: sphere"] * 11))
    with pytest.raises(SceneTooLarge, match=r"scene.yaml:25: meshes.10: .*memory available: .* 640 bytes a triangle"):
        check_scene_size(scene)
    assert check_scene_size(load_scene(yaml_scene(tmp_path, ["shape: sphere"] * 10))) == 10 * SPHERE


def test_just_under_the_limit_is_not_refused(tmp_path):
    scene = load_scene(yaml_scene(tmp_path, ["shape: sphere", "shape: cube", "shape: disk"]))
    total = SPHERE + 12 + P.triangle_count("disk")
    assert check_scene_size(scene, (total, "test")) == total
    with pytest.raises(SceneTooLarge, match=r"meshes\.2: .*at most .* \(test\)"):
        check_scene_size(scene, (total - 1, "test"))


def test_nested_instances_name_the_top_level_one(tmp_path):
    path = tmp_path / "nested.xml"
    path.write_text('<scene version="3.0.0">\n' + CAMERA_XML + '\n'
                    '<shape type="shapegroup" id="a"><shape type="sphere"/><shape type="cube"/></shape>\n'
                    '<shape type="shapegroup" id="b"><shape type="instance"><ref id="a"/></shape></shape>\n'
                    '<shape type="instance"><ref id="b"/></shape>\n'
                    '<shape type="disk"/>\n</scene>\n')
    scene = load_scene(path)
    assert [scene.line("meshes", i, "instance") for i in range(3)] == [5, 5, None]
    with pytest.raises(SceneTooLarge, match=r"nested.xml:5: <shape type=\"instance\">: .*sphere: 32 760"):
        check_scene_size(scene, (100, "test"))
    with pytest.raises(SceneTooLarge, match=r"nested.xml:6: meshes.2: "):
        check_scene_size(scene, (SPHERE + 12, "test"))


# ---- the counts agree with what is built --------------------------------------------------------

@pytest.mark.parametrize("tolerance", [P.TOLERANCE, 1e-6, 1e-2, 0.3, 0.9])
@pytest.mark.parametrize("kind", P.KINDS)
def test_primitive_counts_equal_their_tessellations(kind, tolerance):
    assert P.triangle_count(kind, tolerance) == len(P.make(kind, tolerance).faces)


@pytest.mark.parametrize("kind", P.KINDS)
def test_primitives_lose_no_triangle_when_assembled(kind):
    from mcpt.shapes.mesh import assemble, read_geometry
    from mcpt.shapes.sources import PrimitiveSource

    assert assemble(read_geometry(PrimitiveSource(kind))).num_triangles == P.triangle_count(kind)


def test_obj_count_is_the_fanned_faces(tmp_path, monkeypatch):
    """Triangles, quads and a pentagon, blanks and CRLF, a face split across scan chunks."""
    text = ("# f 1 2 3 is a comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\r\n"
            "f 1 2 3\nf  1 3  4 \r\nf\t1 2 3 4\nf 1 2 3 4 5\nusemtl x\n")
    path = tmp_path / "m.obj"
    path.write_text(text)
    mesh = load_mesh(path)  # the count is before repeated triangles are dropped (2 here)
    assert counts.obj_triangles(path) == 1 + 1 + 2 + 3 == mesh.num_triangles + mesh.dropped_duplicate
    path.write_text(text.replace("f 1 2 3 4 5", "f 1/1/1 2/2/2 3/3/3 4/4/4 5/5/5") + "vt 0 0\nl 1 2\n")
    monkeypatch.setattr(counts, "CHUNK", 7)
    assert counts.obj_triangles(path) == 7


def test_file_counts_match_the_loaders(tmp_path):
    quad = QUAD.astype(float)
    ser = tmp_path / "m.serialized"
    ser.write_bytes(serialized_file([serialized_shape(quad[:3], [[0, 1, 2]]),
                                     serialized_shape(quad, QUAD_FACES)]))
    assert counts.triangles((str(ser), 1)) == 2 and counts.triangles((str(ser), None)) == 1
    g = GltfBuilder()
    mesh = g.mesh(QUAD, QUAD_FACES)
    g.node(mesh=mesh)
    g.node(mesh=mesh, translation=[3, 0, 0])
    g.node(mesh=g.mesh(QUAD, QUAD_FACES[:1]))
    glb = g.write_glb(tmp_path / "m.glb")
    assert counts.triangles((str(glb), None)) == 5 == load_mesh(glb).num_triangles
    assert counts.triangles((str(glb), 1)) == 1
    stl = tmp_path / "m.stl"
    stl.write_text("solid m\n" + "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                   "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\n"
                   "endloop\nendfacet\nendsolid m\n")
    assert counts.triangles((str(stl), None)) == 2 == load_mesh(stl).num_triangles
    off = tmp_path / "m.off"
    off.write_text("OFF\n# a comment\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    assert counts.triangles((str(off), None)) == 2 == load_mesh(off).num_triangles
    (tmp_path / "m.fbx").write_bytes(b"whatever")  # a format without a cheap count: unknown, 0
    assert counts.triangles((str(tmp_path / "m.fbx"), None)) == 0
    assert counts.triangles((str(tmp_path / "gone.obj"), None)) == 0  # its reader says what is wrong


def test_bvh_buffer_bound_behind_the_gl_limit():
    """limits.MAX_TRIANGLES rests on the build making at most F/2 interior nodes where it splits
    at the median (above SAH_MAX_TRIANGLES, or sah=False) and F - 1 with SAH: checked on small
    builds, and the GPU buffer's texels within 5 F + 4 (SAH_MAX_TRIANGLES + 1) + 1."""
    rng = np.random.default_rng(24)
    for n in (5, 9, 1000, 4097):
        tris = rng.random((n, 3, 3)).astype(np.float32)
        tris[: n // 50] *= 40  # a few large triangles: the build gives them their own subtree
        median, sah = build_bvh(tris, sah=False), build_bvh(tris)
        assert (~median.is_leaf).sum() <= n // 2 + 1  # + 1: the root joining the large triangles' subtree
        assert (~sah.is_leaf).sum() <= n - 1
        texels = len(sah.gpu_nodes(tris[sah.order]))
        assert texels <= 5 * n + 4 * (min(n, SAH_MAX_TRIANGLES) + 1) + 1
    assert 5 * limits.MAX_TRIANGLES + 4 * (SAH_MAX_TRIANGLES + 1) + 1 <= limits.GL_BUFFER_TEXELS
