"""Where a mesh entry's triangles come from: a mesh file (Assimp), a Mitsuba ``.serialized``
file, or an analytic primitive -- one dispatch point, one validated :class:`~.mesh.Mesh` out.

Every source goes through the same checks and clean-up as a mesh file (mesh.py ``_assemble``:
transform in float64, mirrored windings, degenerate and duplicated triangles, unit normals), so a
primitive or a .serialized mesh is indistinguishable from an OBJ downstream. ``flip_normals``
(Mitsuba's parameter) turns the front side round: reversed winding, negated normals.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import primitives
from .mesh import Mesh, MeshMaterial, _assemble, _check_transform, _Part, load_mesh
from .serialized import read_serialized


def _part(label: str, positions, faces, normals, uvs, flip: bool, need_normals: bool,
          need_uvs: bool) -> _Part:
    faces = np.asarray(faces, np.int64)
    if flip:
        faces = faces[:, [0, 2, 1]]
        normals = None if normals is None else -normals
    if need_normals and normals is None:
        normals = np.zeros_like(positions)  # _assemble's unit_vertex_normals: area-weighted
    return _Part(label=label, vertices=np.asarray(positions, np.float64), indices=faces.ravel(),
                 material=0, normals=normals if need_normals else None,
                 uvs=uvs if need_uvs else None)


def load_source(spec, transform: np.ndarray | None, *, need_normals: bool = False,
                need_uvs: bool = False) -> Mesh:
    """The mesh of a scene mesh entry ``spec`` (mcpt.scene.Mesh: ``file`` or ``shape``,
    ``shape_index``, ``flip_normals``) placed by ``transform`` (4x4, object to world)."""
    flip = bool(getattr(spec, "flip_normals", False))
    shape = getattr(spec, "shape", None)
    matrix = _check_transform(transform)
    if shape is not None:
        prim = primitives.make(shape)
        name = Path(f"<{shape}>")
        part = _part(shape, prim.positions, prim.faces, prim.normals, prim.uvs, flip, need_normals, need_uvs)
        return _assemble(name, [part], [MeshMaterial("")], matrix, need_normals, need_uvs)
    path = Path(spec.file)
    if path.suffix.lower() == ".serialized":
        m = read_serialized(path, getattr(spec, "shape_index", None) or 0)
        # Mitsuba's uv (0, 0) is the image's top-left; mcpt's is the bottom-left.
        uvs = None if m.uvs is None else np.stack([m.uvs[:, 0], 1.0 - m.uvs[:, 1]], 1)
        part = _part(m.name or "shape", m.positions, m.faces, m.normals, uvs, flip, need_normals, need_uvs)
        return _assemble(path, [part], [MeshMaterial(m.name)], matrix, need_normals, need_uvs)
    mesh = load_mesh(path, transform, need_normals=need_normals, need_uvs=need_uvs)
    if not flip:
        return mesh
    return Mesh(name=mesh.name, vertices=mesh.vertices, faces=np.ascontiguousarray(mesh.faces[:, [0, 2, 1]]),
                face_material=mesh.face_material, materials=mesh.materials,
                normals=None if mesh.normals is None else -mesh.normals, uvs=mesh.uvs,
                dropped_degenerate=mesh.dropped_degenerate, dropped_duplicate=mesh.dropped_duplicate)
