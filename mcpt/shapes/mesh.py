"""Triangle-mesh loading through assimp-py, with validation.

`load_mesh` reads any file Assimp understands (OBJ+MTL, PLY, glTF, ...), merges all of its
sub-meshes into one indexed `Mesh`, applies an optional 4x4 transform in float64 and checks the
result: non-finite vertices, out-of-range indices and files without triangles raise `MeshError`
naming the file (and the sub-mesh where that makes sense); zero-area triangles are dropped and
counted, because they can never be hit and only cost BVH space.

Units: positions are in scene units (whatever the file uses, times the transform); normals are
unit vectors; UVs are the file's raw texture coordinates (OBJ: v points up, no flip applied).

OBJ-specific checks Assimp does not make live in mcpt/shapes/obj.py.

assimp-py 1.1 facts this module relies on (see shared/research/anchors-ecosystem.md, A1):
  * `import_file(str, flags)` takes positional arguments only and a `str` path;
  * the arrays it returns are flat memoryviews freed together with the scene, so everything is
    copied out with `np.array` before the scene is dropped;
  * OBJ files get a synthesised "DefaultMaterial" at index 0, and every material dict carries
    Assimp's defaults (Kd 0.6, Ke 0) whether or not the MTL file gives them, so for OBJ the MTL
    files are scanned to tell "given" from "defaulted".
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import McptError
from . import obj
from ..shading.normals import unit_vertex_normals
from .dedup import first_of_duplicates

__all__ = ["Mesh", "MeshError", "MeshMaterial", "load_mesh"]

log = logging.getLogger("mcpt")

#: A triangle counts as degenerate when |cross(e1, e2)| (twice its area) is at most this times
#: the square of the mesh's bounding-box size. Tiny enough to keep every real sliver triangle.
DEGENERATE_REL_AREA = 1e-30

#: Name Assimp gives the material it invents for faces without `usemtl` (OBJ) and similar.
_ASSIMP_DEFAULT_MATERIAL = "DefaultMaterial"

_ASSIMP_PREFIX = re.compile(r"^Assimp error loading '.*?': ")


class MeshError(McptError):
    """A mesh file cannot be used: unreadable, unsupported, or geometrically invalid."""


@dataclass(frozen=True)
class MeshMaterial:
    """Material information found in the mesh file itself.

    Attributes:
        name: material name (`newmtl` for OBJ); "" when the file gives none.
        kd: diffuse reflectance (linear RGB, each in [0, 1] for a physical material) from MTL
            `Kd` / glTF baseColorFactor, or None when the file does not give one.
        ke: emitted radiance (linear RGB, W sr^-1 m^-2 in scene units) from MTL `Ke` / glTF
            emissiveFactor, or None when the file does not give one.
    """

    name: str
    kd: tuple[float, float, float] | None = None
    ke: tuple[float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class Mesh:
    """An indexed triangle mesh; all arrays are read-only.

    Attributes:
        name: short name, the file stem for loaded meshes.
        vertices: (V, 3) float64 positions in scene units (transform already applied).
        faces: (F, 3) int64 vertex indices, counter-clockwise = front side (right-hand rule).
        face_material: (F,) int32 index into `materials` for every face.
        materials: materials referenced by `face_material` (file order; may include unused ones).
        normals: (V, 3) float32 unit vertex normals, or None when not requested.
        uvs: (V, 2) float32 texture coordinates, or None when not requested / not in the file.
        dropped_degenerate: number of zero-area triangles removed while loading.
        dropped_duplicate: number of repeated triangles (same corners, same winding) removed.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    face_material: np.ndarray
    materials: list[MeshMaterial]
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    dropped_degenerate: int = 0
    dropped_duplicate: int = 0

    def __post_init__(self) -> None:
        # Freeze the arrays too: a frozen dataclass alone would still let callers mutate them.
        for field in ("vertices", "faces", "face_material", "normals", "uvs"):
            arr = getattr(self, field)
            if arr is not None:
                arr.flags.writeable = False

    @property
    def num_triangles(self) -> int:
        """Number of triangles F."""
        return int(self.faces.shape[0])

    def triangles(self) -> np.ndarray:
        """(F, 3, 3) float64 corner positions of every triangle (input of `build_bvh`)."""
        return self.vertices[self.faces]


def load_mesh(
    path: Path,
    transform: np.ndarray | None = None,
    *,
    need_normals: bool = False,
    need_uvs: bool = False,
) -> Mesh:
    """Load every triangle of a mesh file into one `Mesh`.

    Args:
        path: mesh file; any format Assimp reads (OBJ+MTL, PLY, glTF/GLB, STL, ...).
            Node transforms inside the file are applied (Assimp PreTransformVertices).
        transform: optional (4, 4) affine object-to-world matrix, column-vector convention
            (p' = M @ [x, y, z, 1]), applied in float64. A mirroring matrix (det < 0) also
            reverses the winding so that the front side stays the geometric outside.
        need_normals: return unit vertex normals (the file's, else smooth ones generated by
            Assimp), transformed by the inverse transpose. Off by default: generating them costs
            as much as the load itself on big meshes.
        need_uvs: return the first UV channel (None if the file has none).

    Raises:
        MeshError: unreadable or unsupported file, non-triangle primitives, non-finite
            vertices, vertex indices out of range, or no (non-degenerate) triangle at all.
        ValueError: `transform` is not a finite, affine, invertible 4x4 matrix.
    """
    import assimp_py as assimp  # imported here so that `import mcpt.mesh` stays cheap

    path = Path(path)
    matrix = _check_transform(transform)
    if not path.exists():
        raise MeshError(f"{path}: mesh file not found")
    if not path.is_file():
        raise MeshError(f"{path}: not a regular file")

    flags = (
        assimp.Process_Triangulate
        | assimp.Process_JoinIdenticalVertices
        # Bakes node transforms of multi-node formats (glTF, FBX); a no-op for OBJ/PLY.
        | assimp.Process_PreTransformVertices
        # Rejects out-of-range indices before the other steps run: e.g. a PLY face index past
        # the vertex count otherwise makes JoinIdenticalVertices read out of bounds.
        | assimp.Process_ValidateDataStructure
    )
    if need_normals:
        flags |= assimp.Process_GenSmoothNormals  # only fills normals the file lacks

    is_obj = path.suffix.lower() == ".obj"
    if is_obj:
        # Assimp's JoinIdenticalVertices can merge a NaN vertex into another one (NaN compares
        # unequal), which hides it or even yields a plausible wrong triangle: look first, and
        # name the line.
        bad = obj.bad_vertex(path)
        if bad:
            raise MeshError(bad)

    try:
        scene = assimp.import_file(str(path), flags)
    except FileNotFoundError as exc:
        raise MeshError(f"{path}: mesh file not found") from exc
    except ValueError as exc:
        # assimp-py raises this when any face is not a triangle after Triangulate, i.e. the
        # file holds points or lines, which a path tracer cannot render.
        raise MeshError(f"{path}: contains point or line primitives, only triangles are supported") from exc
    except RuntimeError as exc:
        # Drop assimp-py's "Assimp error loading '<path>': " prefix; our message names the file.
        message = _ASSIMP_PREFIX.sub("", str(exc).strip())
        if "No output meshes" in message or "contains no faces" in message:
            raise MeshError(f"{path}: contains no triangles ({message})") from exc
        if is_obj and ("index" in message.lower()):
            where = obj.bad_face(path)
            if where:
                raise MeshError(where) from exc
        raise MeshError(f"{path}: cannot load mesh: {message}") from exc

    # Copy everything out of the scene before it is garbage collected (its buffers die with it).
    parts = []
    for i, m in enumerate(scene.meshes):
        parts.append(
            _Part(
                label=f"sub-mesh #{i} {m.name!r}" if m.name else f"sub-mesh #{i}",
                vertices=np.array(m.vertices, dtype=np.float64).reshape(-1, 3),
                indices=np.array(m.indices, dtype=np.int64),
                material=int(m.material_index),
                normals=(
                    np.array(m.normals, dtype=np.float64).reshape(-1, 3)
                    if need_normals and m.normals is not None
                    else None
                ),
                uvs=_copy_uvs(m) if need_uvs else None,
            )
        )
    materials = _materials(path, scene.materials)
    del scene

    if not parts:
        raise MeshError(f"{path}: contains no triangles")
    if is_obj:
        obj.restore_precision(path, parts)
    return _assemble(path, parts, materials, matrix, need_normals, need_uvs)


@dataclass
class _Part:
    """One Assimp sub-mesh, copied out of the scene (float64 positions, flat int64 indices)."""

    label: str
    vertices: np.ndarray
    indices: np.ndarray
    material: int
    normals: np.ndarray | None
    uvs: np.ndarray | None


def _check_transform(transform: np.ndarray | None) -> np.ndarray | None:
    """Validate a 4x4 affine matrix; returns it as float64 (None stays None)."""
    if transform is None:
        return None
    m = np.asarray(transform, dtype=np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"transform must be 4x4, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError("transform contains non-finite values")
    if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"transform must be affine (last row 0 0 0 1), got {m[3].tolist()}")
    if np.linalg.det(m[:3, :3]) == 0.0:
        raise ValueError("transform is singular (it would flatten the mesh)")
    return m


def _copy_uvs(m) -> np.ndarray | None:
    """First UV channel of an assimp-py mesh as (V, 2) float64, or None."""
    if not m.texcoords or not m.num_uv_components:
        return None
    comps = int(m.num_uv_components[0])
    uv = np.array(m.texcoords[0], dtype=np.float64).reshape(-1, comps)
    if comps >= 2:
        return uv[:, :2]
    return np.concatenate([uv, np.zeros((len(uv), 1))], axis=1)  # 1-D texture coordinates


def _assemble(
    path: Path,
    parts: list[_Part],
    materials: list[MeshMaterial],
    matrix: np.ndarray | None,
    need_normals: bool,
    need_uvs: bool,
) -> Mesh:
    """Validate the sub-meshes, merge them, transform, and drop degenerate triangles."""
    verts, faces, face_mat, normals, uvs = [], [], [], [], []
    offset = 0
    for part in parts:
        nv = len(part.vertices)
        if part.indices.size % 3:
            raise MeshError(f"{path}: {part.label}: index count {part.indices.size} is not a multiple of 3")
        tri = part.indices.reshape(-1, 3)
        bad_vertices = int((~np.isfinite(part.vertices).all(axis=1)).sum())
        if bad_vertices:
            raise MeshError(f"{path}: {part.label}: {bad_vertices} of {nv} vertices are not finite (NaN or inf)")
        out_of_range = int(((tri < 0) | (tri >= nv)).sum())
        if out_of_range:
            raise MeshError(
                f"{path}: {part.label}: {out_of_range} vertex indices out of range [0, {nv}) "
                f"(max {int(tri.max())})"
            )
        if not 0 <= part.material < len(materials):
            raise MeshError(f"{path}: {part.label}: material index {part.material} out of range")
        verts.append(part.vertices)
        faces.append(tri + offset)
        face_mat.append(np.full(len(tri), part.material, dtype=np.int32))
        normals.append(part.normals)
        uvs.append(part.uvs)
        offset += nv

    vertices = np.concatenate(verts)
    face_arr = np.concatenate(faces)
    face_mat_arr = np.concatenate(face_mat)

    normal_arr = None
    if need_normals:
        # GenSmoothNormals fills every sub-mesh; zeros are only a fallback for odd importers.
        normal_arr = np.concatenate([n if n is not None else np.zeros((len(v), 3)) for n, v in zip(normals, verts)])
    uv_arr = None
    if need_uvs and any(u is not None for u in uvs):
        if any(u is None for u in uvs):
            log.info("%s: some sub-meshes have no UVs; using (0, 0) for their vertices", path)
        uv_arr = np.concatenate([u if u is not None else np.zeros((len(v), 2)) for u, v in zip(uvs, verts)])

    if matrix is not None:
        linear = matrix[:3, :3]
        vertices = vertices @ linear.T + matrix[:3, 3]
        bad = int((~np.isfinite(vertices).all(axis=1)).sum())
        if bad:
            raise MeshError(f"{path}: {bad} vertices overflow to non-finite values under the transform")
        big = float(np.abs(vertices).max()) if vertices.size else 0.0
        if big > obj.FLOAT32_MAX:
            # The GPU works in float32: such a mesh cannot be uploaded (issue #6).
            raise MeshError(f"{path}: the transform puts vertices at coordinates up to {big:.3g}, "
                            f"beyond float32 (max {obj.FLOAT32_MAX:.3g})")
        if normal_arr is not None:
            # Normals are covectors: they transform with the inverse transpose.
            normal_arr = normal_arr @ np.linalg.inv(linear)
        if np.linalg.det(linear) < 0:
            # A mirror flips the geometric normal cross(b-a, c-a) relative to the surface; swap
            # two corners so counter-clockwise still means "front side" (emitters are one-sided).
            face_arr = face_arr[:, [0, 2, 1]]

    # Degenerate triangles, measured in float64 after the transform (what will be rendered).
    a, b, c = (vertices[face_arr[:, k]] for k in range(3))
    cross = np.cross(b - a, c - a)
    twice_area = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    scale = float(np.max(vertices.max(axis=0) - vertices.min(axis=0)))
    degenerate = (twice_area == 0.0) | (twice_area <= DEGENERATE_REL_AREA * scale * scale)
    dropped = int(degenerate.sum())
    if dropped:
        log.info("%s: dropped %d degenerate (zero-area) triangles of %d", path, dropped, len(face_arr))
        face_arr = face_arr[~degenerate]
        face_mat_arr = face_mat_arr[~degenerate]
    if len(face_arr) == 0:
        raise MeshError(f"{path}: contains no triangles with non-zero area ({dropped} degenerate dropped)")

    # A triangle written twice (same corners, same winding) is one surface: keep one. Two copies
    # of an emitter would be two lights for next-event estimation but one surface for BSDF-sampled
    # hits, which over-counts direct light (issue #6: +48 % in a Cornell box). The reversed
    # winding is a different surface (a two-sided emitter) and stays.
    unique = first_of_duplicates(face_arr)
    duplicates = int(len(face_arr) - unique.size)
    if duplicates:
        log.info("%s: dropped %d duplicated triangles of %d", path, duplicates, len(face_arr))
        face_arr = face_arr[unique]
        face_mat_arr = face_mat_arr[unique]

    if normal_arr is not None:
        normal_arr = unit_vertex_normals(normal_arr, vertices, face_arr)

    return Mesh(
        name=path.stem,
        vertices=np.ascontiguousarray(vertices),
        faces=np.ascontiguousarray(face_arr, dtype=np.int64),
        face_material=face_mat_arr,
        materials=materials,
        normals=None if normal_arr is None else normal_arr.astype(np.float32),
        uvs=None if uv_arr is None else uv_arr.astype(np.float32),
        dropped_degenerate=dropped,
        dropped_duplicate=duplicates,
    )







def _materials(path: Path, dicts: list[dict]) -> list[MeshMaterial]:
    """Convert assimp-py material dicts, keeping only colours the file really gives."""
    declared = obj.mtl_declarations(path) if path.suffix.lower() == ".obj" else None
    out = []
    for d in dicts:
        name = d.get("NAME") or ""
        kd = _rgb(d.get("COLOR_DIFFUSE"))
        ke = _rgb(d.get("COLOR_EMISSIVE"))
        if name == _ASSIMP_DEFAULT_MATERIAL:
            kd = ke = None  # invented by Assimp, nothing came from the file
        elif declared is not None:
            keys = declared.get(name, set())
            kd = kd if "kd" in keys else None
            ke = ke if "ke" in keys else None
        out.append(MeshMaterial(name=name, kd=kd, ke=ke))
    return out


def _rgb(value) -> tuple[float, float, float] | None:
    if value is None or len(value) < 3:
        return None
    return (float(value[0]), float(value[1]), float(value[2]))


