"""Mesh loading: geometry, transforms, materials from MTL, and every validation error."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from mcpt.shapes.mesh import Mesh, MeshError, MeshMaterial, RawMesh, RawPart, assemble, load_mesh

from .conftest import CORNELL, SPOT
from .merge import merge_meshes

LIGHT = CORNELL / "light.obj"

# The corners of light.obj as written in the file (Assimp parses them to float32).
LIGHT_CORNERS = np.array(
    [[-0.23, 0.99, -0.18], [0.23, 0.99, -0.18], [0.23, 0.99, 0.2], [-0.23, 0.99, 0.2]], np.float32
).astype(np.float64)


def write(path: Path, text: str) -> Path:
    path.write_text(text.lstrip())
    return path


def face_normals(mesh: Mesh) -> np.ndarray:
    t = mesh.triangles()
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_cornell_light():
    mesh = load_mesh(LIGHT)
    assert mesh.name == "light"
    assert mesh.num_triangles == 2 and mesh.dropped_degenerate == 0
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    assert mesh.face_material.dtype == np.int32
    # Same triangles as "f 1 2 3" / "f 1 3 4", whatever vertex order Assimp picked.
    np.testing.assert_array_equal(mesh.triangles(), LIGHT_CORNERS[[[0, 1, 2], [0, 2, 3]]])
    # No MTL: only Assimp's invented default material, with nothing taken from the file.
    assert mesh.materials == [MeshMaterial("DefaultMaterial", None, None)]
    assert mesh.face_material.tolist() == [0, 0]
    assert mesh.normals is None and mesh.uvs is None
    # Front side faces down (-y): the light emits downwards.
    np.testing.assert_allclose(face_normals(mesh), [[0, -1, 0]] * 2, atol=1e-12)
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 1.0  # read-only


def test_transform_is_applied_in_float64():
    angle = np.radians(30.0)
    m = np.eye(4)
    m[:3, :3] = np.array(
        [[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]]
    ) @ np.diag([2.0, 3.0, 0.5])
    m[:3, 3] = [10.0, -1.0, 0.25]
    mesh = load_mesh(LIGHT, m, need_normals=True)
    expected = LIGHT_CORNERS @ m[:3, :3].T + m[:3, 3]
    np.testing.assert_allclose(mesh.triangles(), expected[[[0, 1, 2], [0, 2, 3]]], rtol=0, atol=1e-14)
    # Vertex normals follow the inverse transpose: still -y for this rotation about y + scale.
    assert mesh.normals.dtype == np.float32
    np.testing.assert_allclose(mesh.normals, [[0, -1, 0]] * 4, atol=1e-6)


def test_normals_use_inverse_transpose(tmp_path):
    # A 45-degree slope; a non-uniform scale changes its normal in a way only the inverse
    # transpose gets right (the plain matrix would keep it at 45 degrees).
    obj = write(tmp_path / "slope.obj", "v 0 0 0\nv 1 1 0\nv 0 0 -1\nf 1 2 3\n")
    scale = np.diag([1.0, 2.0, 1.0, 1.0])
    mesh = load_mesh(obj, scale, need_normals=True)
    expected = np.array([-2.0, 1.0, 0.0]) / np.sqrt(5.0)
    np.testing.assert_allclose(face_normals(mesh)[0], expected, atol=1e-12)
    np.testing.assert_allclose(mesh.normals, [expected] * 3, atol=1e-6)


def test_mirror_transform_keeps_front_side():
    mirror = np.diag([1.0, -1.0, 1.0, 1.0])  # y -> -y: the light now faces up
    mesh = load_mesh(LIGHT, mirror, need_normals=True)
    np.testing.assert_allclose(face_normals(mesh), [[0, 1, 0]] * 2, atol=1e-12)
    np.testing.assert_allclose(mesh.normals, [[0, 1, 0]] * 4, atol=1e-6)


def test_bad_transform_rejected():
    with pytest.raises(ValueError, match="4x4"):
        load_mesh(LIGHT, np.eye(3))
    with pytest.raises(ValueError, match="singular"):
        load_mesh(LIGHT, np.diag([1.0, 0.0, 1.0, 1.0]))


def test_mtl_kd_ke(tmp_path):
    write(
        tmp_path / "scene.mtl",
        """
newmtl red
Kd 0.8 0.1 0.1
newmtl lamp
Kd 0 0 0
Ke 10 9 8
newmtl bare
Ns 10
""",
    )
    obj = write(
        tmp_path / "scene.obj",
        """
mtllib scene.mtl
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 0 0 1
usemtl red
f 1 2 3
usemtl lamp
f 2 4 3
usemtl bare
f 1 2 5
""",
    )
    mesh = load_mesh(obj)
    by_name = {m.name: m for m in mesh.materials}
    np.testing.assert_allclose(by_name["red"].kd, [0.8, 0.1, 0.1], rtol=1e-6)
    assert by_name["red"].ke is None
    assert by_name["lamp"].kd == (0.0, 0.0, 0.0)
    assert by_name["lamp"].ke == (10.0, 9.0, 8.0)
    assert by_name["bare"].kd is None and by_name["bare"].ke is None  # Assimp's 0.6 default
    # Each face points at its own material (faces identified by their centroids).
    centroids = [tuple(np.round(c * 3).astype(int).tolist()) for c in mesh.triangles().mean(axis=1)]
    names = {c: mesh.materials[i].name for c, i in zip(centroids, mesh.face_material)}
    assert names == {(1, 1, 0): "red", (2, 2, 0): "lamp", (1, 0, 1): "bare"}


def test_degenerate_triangles_dropped_and_counted(tmp_path, caplog):
    obj = write(
        tmp_path / "degen.obj",
        """
v 0 0 0
v 1 0 0
v 0 1 0
v 2 0 0
f 1 2 3
f 1 2 4
f 1 1 3
""",  # f 2: collinear corners, f 3: repeated corner
    )
    with caplog.at_level(logging.INFO, logger="mcpt"):
        mesh = load_mesh(obj)
    assert mesh.num_triangles == 1 and mesh.dropped_degenerate == 2
    assert any("degen.obj" in r.getMessage() and "2 degenerate" in r.getMessage() for r in caplog.records)


def test_degenerate_and_repeated_triangles_together(tmp_path):
    """Both found side by side (mesh.assemble): the repeats among the triangles that stay, the
    first of each kept, in file order (a degenerate triangle repeated is dropped as degenerate)."""
    obj = write(tmp_path / "both.obj", """
v 0 0 0
v 1 0 0
v 0 1 0
v 2 0 0
v 0 0 1
f 1 1 3
f 2 3 1
f 1 2 4
f 1 2 3
f 1 1 3
f 1 2 5
f 3 1 2
""")
    mesh = load_mesh(obj)
    assert (mesh.dropped_degenerate, mesh.dropped_duplicate) == (3, 2)
    assert mesh.faces.tolist() == [[2, 1, 0], [0, 2, 4]]  # vertices numbered by first use


def test_assemble_leaves_the_readers_arrays_alone():
    """Without a transform the Mesh (whose arrays are read-only) does not share the reader's."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    raw = RawMesh(Path("t.obj"), [RawPart("p", v, np.array([0, 1, 2]), 0)], [MeshMaterial("m")])
    mesh = assemble(raw)
    assert mesh.vertices is not v and v.flags.writeable
    assert np.array_equal(mesh.vertices, v)


def test_only_degenerate_triangles_is_an_error(tmp_path):
    obj = write(tmp_path / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="flat.obj.*no triangles"):
        load_mesh(obj)


@pytest.mark.parametrize(
    "name, text, match",
    [
        ("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "not finite"),
        ("inf.obj", "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n", "not finite"),
        ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "out of range"),
        (
            "range.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n",
            "out of range",
        ),
        ("unsupported.xyz", "hello world\n", "cannot load"),
        ("lines.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2\n", "only triangles"),
        ("novertsused.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangles"),
    ],
)
def test_invalid_files_raise_mesh_error(tmp_path, name, text, match):
    path = write(tmp_path / name, text)
    with pytest.raises(MeshError, match=match) as info:
        load_mesh(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message


def test_missing_file(tmp_path):
    with pytest.raises(MeshError, match="missing.obj.*not found"):
        load_mesh(tmp_path / "missing.obj")
    with pytest.raises(MeshError, match="not a regular file"):
        load_mesh(tmp_path)


def test_own_index_check_names_sub_mesh(tmp_path):
    # Assimp's validation normally catches this first; the loader checks again for importers
    # that do not, and must name the file and the sub-mesh.
    part = RawPart("sub-mesh #0 'body'", np.zeros((3, 3)), np.array([0, 1, 5]), 0, None, None)
    with pytest.raises(MeshError, match=r"x\.ply: sub-mesh #0 'body': 1 vertex indices out of range"):
        assemble(RawMesh(Path("x.ply"), [part], [MeshMaterial("m")]))


def test_uvs_and_normals_only_on_request():
    plain = load_mesh(SPOT)
    assert plain.normals is None and plain.uvs is None
    full = load_mesh(SPOT, need_normals=True, need_uvs=True)
    assert full.uvs.shape == (len(full.vertices), 2) and full.uvs.dtype == np.float32
    # The file's raw `vt` values, unflipped.
    vt = np.array(
        [line.split()[1:3] for line in SPOT.read_text().splitlines() if line.startswith("vt ")], np.float32
    )
    assert set(map(tuple, full.uvs.tolist())) == set(map(tuple, vt.tolist()))
    np.testing.assert_allclose(np.linalg.norm(full.normals, axis=1), 1.0, atol=1e-6)
    assert full.num_triangles == plain.num_triangles == 5856


def test_merge_meshes_offsets_indices_and_maps_materials():
    light = load_mesh(LIGHT)
    walls = load_mesh(CORNELL / "red_wall.obj")
    merged = merge_meshes([(walls, [3]), (light, [1])], name="cornell")
    assert merged.num_triangles == 4
    np.testing.assert_array_equal(merged.triangles()[:2], walls.triangles())
    np.testing.assert_array_equal(merged.triangles()[2:], light.triangles())
    assert merged.face_material.tolist() == [3, 3, 1, 1]
    assert len(merged.materials) == 4 and merged.materials[0] == MeshMaterial("")
    # None appends the mesh's own materials after the highest id used so far.
    appended = merge_meshes([(walls, [3]), (light, None)])
    assert appended.face_material.tolist() == [3, 3, 4, 4]
    with pytest.raises(ValueError, match="material_id_map"):
        merge_meshes([(light, [0, 1])])
