"""Geometry as a reader hands it over, before mcpt/shapes/mesh.py validates and merges it.

Every geometry reader (Assimp for mesh files today; analytic primitives and Mitsuba's
``.serialized`` files plug in beside it, see ``mesh.READERS``) returns a :class:`RawMesh`: one or
more :class:`RawPart` sub-meshes as plain numpy arrays, and the materials the source itself
names (:class:`MeshMaterial`, what an OBJ's MTL or a glTF file says; analytic shapes have none).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..errors import McptError


class MeshError(McptError):
    """A mesh file cannot be used: unreadable, unsupported, or geometrically invalid."""


@dataclass(frozen=True)
class TextureMap:
    """An image a mesh file gives as a material colour (an MTL ``map_Kd``, ...).

    Attributes:
        declared_in: the file that names the image (the MTL file), for messages.
        keyword: the statement that names it as the file spells it (``map_Kd``), for messages.
        file: the image, resolved as its format says (MTL: relative to the MTL's folder).
    """

    declared_in: Path
    keyword: str
    file: Path


@dataclass(frozen=True)
class MeshMaterial:
    """Material information found in the mesh file itself.

    Attributes:
        name: material name (`newmtl` for OBJ); "" when the file gives none.
        kd: diffuse reflectance (linear RGB, each in [0, 1] for a physical material) from MTL
            `Kd` / glTF baseColorFactor, or None when the file does not give one.
        ke: emitted radiance (linear RGB, W sr^-1 m^-2 in scene units) from MTL `Ke` / glTF
            emissiveFactor, or None when the file does not give one.
        kd_map: an image for the diffuse colour (MTL ``map_Kd``), or None.
        ke_map: an image for the emitted radiance (MTL ``map_Ke``), or None.
        d_map: a grey image of the opacity (MTL ``map_d``: a cut-out), or None.
    """

    name: str
    kd: tuple[float, float, float] | None = None
    ke: tuple[float, float, float] | None = None
    kd_map: TextureMap | None = None
    ke_map: TextureMap | None = None
    d_map: TextureMap | None = None


@dataclass
class RawPart:
    """One sub-mesh as read, in the source's own units (before the scene's transform).

    Attributes:
        label: names the sub-mesh in messages ("sub-mesh #0 'body'").
        vertices: (V, 3) float64 positions.
        indices: vertex indices, three per triangle, counter-clockwise = front side: flat (3F,)
            or (F, 3), any integer type (checked by mesh.assemble: range, multiple of 3).
        material: index into :attr:`RawMesh.materials` for every triangle of the part.
        normals: (V, 3) vertex normals (any length; normalised later), or None.
        uvs: (V, 2) texture coordinates (v up), or None.
    """

    label: str
    vertices: np.ndarray
    indices: np.ndarray
    material: int = 0
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None


@dataclass
class RawMesh:
    """What a geometry reader returns: the source (named in messages), its parts and materials.

    A source without materials of its own gives one nameless :class:`MeshMaterial` (the scene's
    YAML material then decides everything)."""

    source: Path
    parts: list[RawPart]
    materials: list[MeshMaterial] = field(default_factory=lambda: [MeshMaterial("")])


@dataclass(frozen=True)
class FileShape:
    """Shape ``index`` of a file that holds several (a Mitsuba ``.serialized``, a glTF): a geometry
    source whose ``kind`` names its reader in ``mesh.READERS``; ``what`` names one in messages."""

    path: Path
    index: int = 0
    kind: str = ""
    what: ClassVar[str] = "shape"

    def __str__(self) -> str:
        return f"{self.path} ({self.what} {self.index})"
