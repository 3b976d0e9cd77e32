"""Geometry sources beside mesh files (issue #19): analytic primitives and Mitsuba's
``.serialized`` shapes, plugged into mesh.py's one dispatch point (``READERS``), and
``flip_normals``.

Each reader hands mesh.py a :class:`~.raw_mesh.RawMesh` like Assimp's, so a primitive or a
.serialized shape goes through the same checks and clean-up as an OBJ (mesh.assemble: transform in
float64, mirrored windings, degenerate and repeated triangles) and is indistinguishable downstream.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import primitives
from .mesh import READERS
from .raw_mesh import FileShape, MeshMaterial, RawMesh, RawPart
from .serialized import read_serialized


@dataclass(frozen=True)
class PrimitiveSource:
    """An analytic shape in its own frame (mcpt/shapes/primitives.py); ``kind`` names its reader."""

    kind: str

    def __str__(self) -> str:
        return f"<{self.kind}>"


@dataclass(frozen=True)
class SerializedShape(FileShape):
    """Shape ``index`` of a Mitsuba ``.serialized`` file."""

    kind: str = ".serialized"


def source_of(spec):
    """The geometry source of a scene mesh entry (mcpt.scene.Mesh): its ``shape``, a
    ``.serialized`` file's shape ``shape_index``, or the mesh file's path."""
    if spec.shape is not None:
        return PrimitiveSource(spec.shape)
    path = Path(spec.file)
    if path.suffix.lower() == ".serialized":
        if not path.is_file():
            from .raw_mesh import MeshError

            raise MeshError(f"{path}: mesh file not found")
        return SerializedShape(path, spec.shape_index or 0)
    if path.suffix.lower() in (".gltf", ".glb") and spec.shape_index is not None:  # issue #19: glTF
        from .gltf_source import GltfPrimitive

        return GltfPrimitive(path, spec.shape_index)
    return path


def _read_primitive(source: PrimitiveSource, *, need_normals: bool = False) -> RawMesh:
    p = primitives.make(source.kind)
    part = RawPart(source.kind, p.positions, p.faces, 0, p.normals, p.uvs)
    return RawMesh(Path(str(source)), [part])


def _read_serialized(source: SerializedShape, *, need_normals: bool = False) -> RawMesh:
    m = read_serialized(source.path, source.index)
    # Mitsuba's uv (0, 0) is the image's top-left; mcpt's v points up.
    uvs = None if m.uvs is None else np.stack([m.uvs[:, 0], 1.0 - m.uvs[:, 1]], 1)
    part = RawPart(m.name or "shape", m.positions, m.faces, 0, m.normals, uvs)
    return RawMesh(source.path, [part], [MeshMaterial(m.name or "")])


def flipped(raw: RawMesh) -> RawMesh:
    """Mitsuba's ``flip_normals``: every front side turned round (reversed winding, negated normals)."""
    parts = [RawPart(p.label, p.vertices, np.asarray(p.indices).reshape(-1, 3)[:, ::-1].copy(), p.material,
                     None if p.normals is None else -np.asarray(p.normals), p.uvs) for p in raw.parts]
    return RawMesh(raw.source, parts, raw.materials)


READERS[".serialized"] = _read_serialized
for _kind in primitives.KINDS:
    READERS[_kind] = _read_primitive

from . import gltf_source  # noqa: E402, F401  issue #19: registers the glTF readers
