"""Test helper: concatenate loaded meshes into one (no renderer code needs this)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mcpt.shapes.mesh import Mesh, MeshMaterial


def merge_meshes(
    parts: Sequence[tuple[Mesh, Sequence[int] | np.ndarray | None]],
    name: str = "merged",
) -> Mesh:
    """Concatenate meshes into one, offsetting vertex indices and remapping material ids.

    Args:
        parts: `(mesh, material_id_map)` pairs. `material_id_map[k]` is the id in the result
            of the mesh's local material k (an int sequence of length `len(mesh.materials)`),
            typically an index into the caller's scene-wide material table. With None the
            mesh's materials are appended after the highest id used so far.
        name: name of the merged mesh.

    Returns:
        A `Mesh` whose `face_material` holds the mapped ids. `materials[g]` is the first file
        material mapped to id g (ids nobody maps to get an empty placeholder), so the invariant
        "face_material indexes materials" still holds. Normals / UVs are kept only when every
        part has them. `dropped_degenerate` is the sum over the parts.
    """
    if not parts:
        raise ValueError("merge_meshes needs at least one mesh")
    merged_materials: dict[int, MeshMaterial] = {}
    verts, faces, face_mat, normals, uvs = [], [], [], [], []
    offset = 0
    for mesh, id_map in parts:
        if id_map is None:
            base = max(merged_materials, default=-1) + 1
            id_map = np.arange(base, base + len(mesh.materials))
        id_map = np.asarray(id_map, dtype=np.int64)
        if id_map.shape != (len(mesh.materials),) or (id_map.size and id_map.min() < 0):
            raise ValueError(
                f"material_id_map of mesh {mesh.name!r} must hold {len(mesh.materials)} "
                f"non-negative ids, got shape {id_map.shape}"
            )
        for local, global_id in enumerate(id_map.tolist()):
            merged_materials.setdefault(global_id, mesh.materials[local])
        verts.append(mesh.vertices)
        faces.append(mesh.faces + offset)
        face_mat.append(id_map[mesh.face_material])
        normals.append(mesh.normals)
        uvs.append(mesh.uvs)
        offset += len(mesh.vertices)

    top = max(merged_materials, default=-1) + 1
    if top > np.iinfo(np.int32).max:
        raise ValueError("material id does not fit int32")
    return Mesh(
        name=name,
        vertices=np.concatenate(verts),
        faces=np.concatenate(faces),
        face_material=np.concatenate(face_mat).astype(np.int32),
        materials=[merged_materials.get(g, MeshMaterial("")) for g in range(top)],
        normals=None if any(n is None for n in normals) else np.concatenate(normals),
        uvs=None if any(u is None for u in uvs) else np.concatenate(uvs),
        dropped_degenerate=sum(mesh.dropped_degenerate for mesh, _ in parts),
        dropped_duplicate=sum(mesh.dropped_duplicate for mesh, _ in parts),
    )


# --------------------------------------------------------------------------------------------
# internals


