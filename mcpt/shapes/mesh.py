"""Triangle meshes: the one road from a geometry source to a validated, indexed `Mesh`.

`read_geometry` dispatches a source to its reader (`READERS`; Assimp for mesh files), and
`assemble` merges the reader's sub-meshes into one `Mesh`, applies an optional 4x4 transform in
float64 and checks the result: non-finite vertices, out-of-range indices and sources without
triangles raise `MeshError` naming the file (and the sub-mesh where that makes sense);
zero-area triangles are dropped and counted, because they can never be hit and only cost BVH
space; a triangle listed twice is kept once. `load_mesh` is the two in a row.

Units: positions are in scene units (whatever the file uses, times the transform); normals are
unit vectors; UVs are the file's raw texture coordinates (OBJ: v points up, no flip applied).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..parallel import side_by_side
from ..shading.normals import unit_vertex_normals
from .assimp_file import read_assimp
from .dedup import first_of_duplicates
from .geometry import column_bounds
from .obj import FLOAT32_MAX
from .ply import read_ply
from .raw_mesh import MeshError, MeshMaterial, RawMesh, RawPart, TextureMap

__all__ = ["READERS", "Mesh", "MeshError", "MeshMaterial", "RawMesh", "RawPart", "TextureMap", "assemble",
           "load_mesh", "read_geometry"]

log = logging.getLogger("mcpt")

#: A triangle counts as degenerate when |cross(e1, e2)| (twice its area) is at most this times
#: the square of the mesh's bounding-box size. Tiny enough to keep every real sliver triangle.
DEGENERATE_REL_AREA = 1e-30

_IDENTITY = np.eye(4)

#: A geometry reader: ``reader(source, need_normals=...) -> RawMesh`` (contract: read_geometry).
Reader = Callable[..., RawMesh]

#: Geometry readers by source kind: a mesh file's lower-case suffix, or the ``kind`` of a
#: non-file source (an analytic primitive). Mesh files of any other suffix go to Assimp; PLY is
#: read by mcpt (issue #24 item 14: Assimp's reader shifts binary data that starts with a
#: whitespace byte).
READERS: dict[str, Reader] = {".ply": read_ply}


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


def read_geometry(source, *, need_normals: bool = False) -> RawMesh:
    """Read a geometry source with the reader its kind names: the one dispatch point.

    A source is a mesh file's ``Path`` (kind: its lower-case suffix, e.g. ``".serialized"``; a
    suffix without a reader of its own goes to Assimp, mcpt/shapes/assimp_file.py), or any other
    object with a ``kind`` string naming its reader (an analytic primitive: ``"sphere"``). A new
    source plugs in with one line: ``READERS[kind] = reader``.

    The reader contract: ``reader(source, need_normals=bool) -> RawMesh`` (mcpt/shapes/raw_mesh.py)
    whose parts hold (V, 3) float64 positions and int vertex indices (three per triangle,
    counter-clockwise = front side), and optionally (V, 3) vertex normals and (V, 2) UVs (v up);
    ``need_normals`` says the caller will use normals (a reader may return them anyway, or
    none: mcpt then shades flat). Positions are the source's own, before the scene's transform.
    A source's materials are optional. A reader raises `MeshError` naming the source for what it
    cannot read; `assemble` checks ranges, finiteness and triangle count for every reader.
    """
    if isinstance(source, Path):
        if not source.exists():
            raise MeshError(f"{source}: mesh file not found")
        if not source.is_file():
            raise MeshError(f"{source}: not a regular file")
        reader = READERS.get(source.suffix.lower(), read_assimp)
    elif source.kind in READERS:
        reader = READERS[source.kind]
    else:
        raise MeshError(f"{source}: no geometry reader for {source.kind!r} (known: {', '.join(READERS)})")
    return reader(source, need_normals=need_normals)


def load_mesh(
    path: Path,
    transform: np.ndarray | None = None,
    *,
    need_normals: bool = False,
    need_uvs: bool = False,
) -> Mesh:
    """Load every triangle of a mesh file into one `Mesh` (`read_geometry`, then `assemble`).

    Args:
        path: mesh file; any format Assimp reads (OBJ+MTL, STL, ...) or one of
            `READERS`. Node transforms inside the file are applied (Assimp PreTransformVertices).
        transform, need_normals, need_uvs: as for `assemble`.

    Raises:
        MeshError: unreadable or unsupported file, non-triangle primitives, non-finite
            vertices, vertex indices out of range, or no (non-degenerate) triangle at all.
        ValueError: `transform` is not a finite, affine, invertible 4x4 matrix.
    """
    matrix = _check_transform(transform)
    raw = read_geometry(Path(path), need_normals=need_normals)
    return assemble(raw, matrix, need_normals=need_normals, need_uvs=need_uvs)


def assemble(
    raw: RawMesh,
    transform: np.ndarray | None = None,
    *,
    need_normals: bool = False,
    need_uvs: bool = False,
) -> Mesh:
    """Validate a reader's sub-meshes, merge them, transform, drop degenerate and repeated triangles.

    Args:
        raw: what `read_geometry` returned.
        transform: optional (4, 4) affine object-to-world matrix, column-vector convention
            (p' = M @ [x, y, z, 1]), applied in float64. A mirroring matrix (det < 0) also
            reverses the winding so that the front side stays the geometric outside.
        need_normals: return unit vertex normals, transformed by the inverse transpose (zeros
            where a part has none).
        need_uvs: return the first UV channel (None if no part has one).
    """
    path, matrix = raw.source, _check_transform(transform)
    vertices, face_arr, face_mat_arr, normal_arr, uv_arr = _merge(raw, need_normals, need_uvs)

    if matrix is not None:
        vertices, face_arr, normal_arr = _transform(path, matrix, vertices, face_arr, normal_arr)
    elif vertices is raw.parts[0].vertices:
        vertices = vertices.copy()  # the Mesh's arrays are made read-only: not the caller's

    # Degenerate triangles, measured in float64 after the transform (what will be rendered), and
    # repeated ones (below) need nothing from each other: found side by side on the thread pool,
    # the areas in two halves (issue #23: 0.28 s in one thread at 10^6 triangles). The repeats
    # are searched again only where degenerate triangles were dropped (rare), so the result is
    # the sequential one.
    half = len(face_arr) // 2
    first_half, second_half, unique, (lo, hi) = side_by_side(
        lambda: _twice_areas(vertices, face_arr[:half]), lambda: _twice_areas(vertices, face_arr[half:]),
        lambda: first_of_duplicates(face_arr), lambda: column_bounds(vertices))
    twice_area = np.concatenate([first_half, second_half])
    scale = float(np.max(hi - lo))
    degenerate = (twice_area == 0.0) | (twice_area <= DEGENERATE_REL_AREA * scale * scale)
    dropped = int(degenerate.sum())
    if dropped:
        log.info("%s: dropped %d degenerate (zero-area) triangles of %d", path, dropped, len(face_arr))
        face_arr = face_arr[~degenerate]
        face_mat_arr = face_mat_arr[~degenerate]
        if len(face_arr):
            unique = first_of_duplicates(face_arr)
    if len(face_arr) == 0:
        raise MeshError(f"{path}: contains no triangles with non-zero area ({dropped} degenerate dropped)")

    # A triangle written twice (same corners, same winding) is one surface: keep one. Two copies
    # of an emitter would be two lights for next-event estimation but one surface for BSDF-sampled
    # hits, which over-counts direct light (issue #6: +48 % in a Cornell box). The reversed
    # winding is a different surface (a two-sided emitter) and stays.
    duplicates = int(len(face_arr) - unique.size)
    if duplicates:
        log.info("%s: dropped %d duplicated triangles of %d", path, duplicates, len(face_arr))
        face_arr = face_arr[unique]
        face_mat_arr = face_mat_arr[unique]

    if normal_arr is not None:
        normal_arr = unit_vertex_normals(normal_arr, vertices, face_arr)

    return Mesh(
        name=Path(path).stem,
        vertices=np.ascontiguousarray(vertices),
        faces=np.ascontiguousarray(face_arr, dtype=np.int64),
        face_material=face_mat_arr,
        materials=raw.materials,
        normals=None if normal_arr is None else normal_arr.astype(np.float32),
        uvs=None if uv_arr is None else uv_arr.astype(np.float32),
        dropped_degenerate=dropped,
        dropped_duplicate=duplicates,
    )


def _twice_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F,) twice the float64 area of every triangle: |np.cross(b - a, c - a)|, row by row (the
    same bits for any split of the rows)."""
    cross = _cross_of_edges(vertices, faces)
    return np.sqrt(np.einsum("ij,ij->i", cross, cross))


def _cross_of_edges(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 3) ``np.cross(b - a, c - a)`` of every triangle, with np.cross's own products and
    differences (the same bits), an axis at a time: gathers from 1-D columns and 1-D products
    cost a third of row gathers and np.cross's (F, 3) temporaries (0.2 s at 10^6, issue #23)."""
    a, b, c = (np.ascontiguousarray(faces[:, k]) for k in range(3))
    e1, e2 = [], []
    for k in range(3):
        col = np.ascontiguousarray(vertices[:, k])
        ak = col[a]
        e1.append(col[b] - ak)
        e2.append(col[c] - ak)
    out = np.empty((len(faces), 3))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        np.multiply(e1[i], e2[j], out=out[:, k])
        out[:, k] -= e1[j] * e2[i]
    return out


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


def _merge(raw: RawMesh, need_normals: bool, need_uvs: bool):
    """Check every part and concatenate them: (vertices, faces, face material, normals, uvs)."""
    path, materials = raw.source, raw.materials
    if not raw.parts:
        raise MeshError(f"{path}: contains no triangles")
    verts, faces, face_mat, normals, uvs = [], [], [], [], []
    offset = 0
    for part in raw.parts:
        nv = len(part.vertices)
        indices = np.asarray(part.indices).reshape(-1)
        if indices.size % 3:
            raise MeshError(f"{path}: {part.label}: index count {indices.size} is not a multiple of 3")
        tri = indices.astype(np.int64).reshape(-1, 3)
        # Counted only when some value is bad: the row-wise count costs 4x the whole-array test.
        bad_vertices = 0 if np.isfinite(part.vertices).all() else int((~np.isfinite(part.vertices).all(axis=1)).sum())
        if bad_vertices:
            raise MeshError(f"{path}: {part.label}: {bad_vertices} of {nv} vertices are not finite (NaN or inf)")
        in_range = tri.size == 0 or (tri.min() >= 0 and tri.max() < nv)
        out_of_range = 0 if in_range else int(((tri < 0) | (tri >= nv)).sum())
        if out_of_range:
            raise MeshError(
                f"{path}: {part.label}: {out_of_range} vertex indices out of range [0, {nv}) "
                f"(max {int(tri.max())})"
            )
        if not 0 <= part.material < len(materials):
            raise MeshError(f"{path}: {part.label}: material index {part.material} out of range")
        verts.append(np.asarray(part.vertices, np.float64))
        faces.append(tri + offset if offset else tri)
        face_mat.append(np.full(len(tri), part.material, dtype=np.int32))
        normals.append(part.normals)
        uvs.append(part.uvs)
        offset += nv

    normal_arr = None
    if need_normals:
        # Zeros where a part has none: unit_vertex_normals generates them (angle-weighted, as Mitsuba).
        normal_arr = np.concatenate([n if n is not None else np.zeros((len(v), 3)) for n, v in zip(normals, verts)])
    uv_arr = None
    if need_uvs and any(u is not None for u in uvs):
        if any(u is None for u in uvs):
            log.info("%s: some sub-meshes have no UVs; using (0, 0) for their vertices", path)
        uv_arr = np.concatenate([u if u is not None else np.zeros((len(v), 2)) for u, v in zip(uvs, verts)])
    # One part (an OBJ without groups): its arrays as they are, no copy (40 ms at 10^6 triangles).
    joined = [x[0] if len(x) == 1 else np.concatenate(x) for x in (verts, faces, face_mat)]
    return (*joined, normal_arr, uv_arr)


def _transform(path, matrix: np.ndarray, vertices: np.ndarray, faces: np.ndarray, normals):
    """Vertices, faces and normals under the object-to-world ``matrix``."""
    linear = matrix[:3, :3]
    if np.array_equal(matrix, _IDENTITY):
        # What the product below gives for the identity, exactly: x*1 plus zeros is x, and the
        # added translation 0.0 turns -0.0 into 0.0. A scene mesh without a transform gets the
        # identity, and the (V, 3) @ (3, 3) product costs 0.1 s at 5*10^5 vertices (issue #23).
        vertices = vertices + 0.0
    else:
        vertices = vertices @ linear.T + matrix[:3, 3]
    bad = 0 if np.isfinite(vertices).all() else int((~np.isfinite(vertices).all(axis=1)).sum())
    if bad:
        raise MeshError(f"{path}: {bad} vertices overflow to non-finite values under the transform")
    big = float(np.abs(vertices).max()) if vertices.size else 0.0
    if big > FLOAT32_MAX:
        # The GPU works in float32: such a mesh cannot be uploaded (issue #6).
        raise MeshError(f"{path}: the transform puts vertices at coordinates up to {big:.3g}, "
                        f"beyond float32 (max {FLOAT32_MAX:.3g})")
    if normals is not None:
        # Normals are covectors: they transform with the inverse transpose.
        normals = normals @ np.linalg.inv(linear)
    if np.linalg.det(linear) < 0:
        # A mirror flips the geometric normal cross(b-a, c-a) relative to the surface; swap
        # two corners so counter-clockwise still means "front side" (emitters are one-sided).
        faces = faces[:, [0, 2, 1]]
    return vertices, faces, normals
