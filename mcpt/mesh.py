"""Triangle-mesh loading through assimp-py, with validation.

`load_mesh` reads any file Assimp understands (OBJ+MTL, PLY, glTF, ...), merges all of its
sub-meshes into one indexed `Mesh`, applies an optional 4x4 transform in float64 and checks the
result: non-finite vertices, out-of-range indices and files without triangles raise `MeshError`
naming the file (and the sub-mesh where that makes sense); zero-area triangles are dropped and
counted, because they can never be hit and only cost BVH space.

Units: positions are in scene units (whatever the file uses, times the transform); normals are
unit vectors; UVs are the file's raw texture coordinates (OBJ: v points up, no flip applied).

Combining meshes: `merge_meshes` concatenates several loaded meshes into one (vertex indices
offset, material ids remapped to the caller's global material table), so a scene can be turned
into one triangle array for `mcpt.bvh.build_bvh` without a per-object Python loop over triangles.

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
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Mesh", "MeshError", "MeshMaterial", "load_mesh", "merge_meshes"]

log = logging.getLogger("mcpt")

#: A triangle counts as degenerate when |cross(e1, e2)| (twice its area) is at most this times
#: the square of the mesh's bounding-box size. Tiny enough to keep every real sliver triangle.
DEGENERATE_REL_AREA = 1e-30

#: Name Assimp gives the material it invents for faces without `usemtl` (OBJ) and similar.
_ASSIMP_DEFAULT_MATERIAL = "DefaultMaterial"

_ASSIMP_PREFIX = re.compile(r"^Assimp error loading '.*?': ")


class MeshError(Exception):
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
        _check_obj_vertices(path)

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
            where = _obj_bad_face(path)
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
        _restore_obj_precision(path, parts)
    return _assemble(path, parts, materials, matrix, need_normals, need_uvs)


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
        if big > _FLOAT32_MAX:
            # The GPU works in float32: such a mesh cannot be uploaded (issue #6).
            raise MeshError(f"{path}: the transform puts vertices at coordinates up to {big:.3g}, "
                            f"beyond float32 (max {_FLOAT32_MAX:.3g})")
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
        normal_arr = _unit_normals(normal_arr, vertices, face_arr)

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


# --------------------------------------------------------------------------------------------
# OBJ specifics: line numbers for bad vertices and faces, float64 coordinates far from the origin

_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)
_OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]+([^\r\n#]*)", re.MULTILINE)
_FLOAT32_MAX = float(np.finfo(np.float32).max)

#: Assimp parses OBJ coordinates as float32. When a mesh's coordinates are more than this many
#: times its own size, the rounding is visible (relative to the mesh), so the file's own float64
#: values are read back (see _restore_obj_precision).
OBJ_FLOAT64_RATIO = 64.0


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _check_obj_vertices(path: Path) -> None:
    """MeshError naming ``file:line`` for the first vertex that is NaN, infinite or beyond
    float32 (Assimp would read the latter as inf). A quick byte search skips clean files."""
    try:
        data = path.read_bytes()
    except OSError:
        return  # Assimp reports unreadable files
    low = (b"nan", b"NaN", b"NAN", b"inf", b"Inf", b"INF")
    if not any(t in data for t in low) and re.search(rb"[eE]\+?(3[89]|[4-9]\d|\d{3})", data) is None:
        return
    for k, m in enumerate(_OBJ_VERTEX.finditer(data)):
        try:
            xyz = [float(t) for t in m.groups()]
        except ValueError:
            continue  # Assimp decides what to do with a malformed number
        if not all(math.isfinite(x) and abs(x) <= _FLOAT32_MAX for x in xyz):
            text = data[m.start():data.find(b"\n", m.start())].decode("utf-8", "replace").strip()
            raise MeshError(f"{path}:{_line_of(data, m.start())}: vertex {k + 1} is not finite "
                            f"(NaN, inf or beyond float32): {text!r}")


def _obj_bad_face(path: Path) -> str | None:
    """'file:line: ...' for the first face whose vertex index is out of range, or None."""
    data = path.read_bytes()
    count = 0
    ends = [m.start() for m in _OBJ_VERTEX.finditer(data)]
    total = len(ends)
    for m in _OBJ_FACE.finditer(data):
        before = int(np.searchsorted(ends, m.start()))  # vertices defined above this face
        for tok in m.group(1).split():
            try:
                i = int(tok.split(b"/")[0])
            except ValueError:
                return f"{path}:{_line_of(data, m.start())}: face index {tok.decode(errors='replace')!r} is not an integer"
            ok = 1 <= i <= total if i > 0 else (i < 0 and -i <= before)
            if not ok:
                return (f"{path}:{_line_of(data, m.start())}: face vertex index {i} out of range "
                        f"(the file has {total} vertices, indices are 1-based)")
        count += 1
    return None


def _restore_obj_precision(path: Path, parts: list) -> None:
    """Replace Assimp's float32 coordinates by the file's float64 ones where it matters.

    A Cornell box written at x = 1e5 loses everything below 1/128 in float32, before mcpt's
    camera-relative float64 rebasing could keep it (issue #6). Every Assimp vertex is the float32
    rounding of some file vertex; where that file vertex is unique the float64 value is restored.
    If two different file vertices round to the same float32 vertex, Assimp has already merged
    them: precision is lost and a warning says so (a YAML ``transform`` keeps far-away meshes
    exact)."""
    allv = np.concatenate([p.vertices for p in parts])
    if allv.size == 0 or not np.isfinite(allv).all():
        return
    extent = float(np.max(allv.max(axis=0) - allv.min(axis=0)))
    if float(np.abs(allv).max()) <= OBJ_FLOAT64_RATIO * max(extent, 1e-300):
        return
    data = path.read_bytes()
    try:
        exact = np.array([[float(t) for t in m.groups()] for m in _OBJ_VERTEX.finditer(data)])
    except ValueError:
        return
    if exact.size == 0:
        return
    keys = np.ascontiguousarray(exact.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
    order = np.argsort(keys, kind="stable")
    sk, se = keys[order], exact[order]
    clash = (sk[1:] == sk[:-1]) & np.any(se[1:] != se[:-1], axis=1)
    if clash.any():
        log.warning("%s: %d vertices differ only below float32 precision at coordinates up to %.3g:"
                    " they were merged; place the mesh with a YAML transform instead of far-away"
                    " coordinates", path, int(clash.sum()), float(np.abs(exact).max()))
        return
    for p in parts:
        q = np.ascontiguousarray(p.vertices.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
        pos = np.searchsorted(sk, q)
        pos = np.minimum(pos, len(sk) - 1)
        found = sk[pos] == q
        p.vertices = np.where(found[:, None], se[pos], p.vertices)


def first_of_duplicates(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of the first occurrence of every triangle, equal up to a cyclic rotation
    of its corners (index based: Assimp's JoinIdenticalVertices gives equal corners equal indices)."""
    if len(faces) < 2:
        return np.arange(len(faces))
    r = np.argmin(faces, axis=1)
    canon = np.take_along_axis(faces, (r[:, None] + np.arange(3)) % 3, axis=1).astype(np.int64)
    n = int(canon.max()) + 1
    if n < 1 << 21:  # one int64 key per triangle
        _, first = np.unique((canon[:, 0] << 42) | (canon[:, 1] << 21) | canon[:, 2], return_index=True)
    else:
        order = np.lexsort((canon[:, 2], canon[:, 1], canon[:, 0]))
        c = canon[order]
        new = np.ones(len(c), bool)
        new[1:] = np.any(c[1:] != c[:-1], axis=1)
        # lexsort is stable, so the first of each run is the earliest occurrence
        first = order[new]
    return np.sort(first)


def _unit_normals(normals: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Renormalise vertex normals; zero / non-finite ones fall back to area-weighted face normals.

    Assimp leaves a zero normal where all adjacent faces were degenerate or the file gave a
    broken one; a zero normal would turn into NaN in the shader's normalize().
    """
    length = np.linalg.norm(normals, axis=1)
    broken = ~(np.isfinite(length) & (length > 0))
    out = normals / np.where(broken, 1.0, length)[:, None]
    if broken.any():
        a, b, c = (vertices[faces[:, k]] for k in range(3))
        face_n = np.cross(b - a, c - a)  # length = 2 * area, so the sum is area weighted
        acc = np.zeros_like(vertices)
        for k in range(3):
            np.add.at(acc, faces[:, k], face_n)
        acc_len = np.linalg.norm(acc[broken], axis=1)
        fixed = np.zeros((int(broken.sum()), 3))
        ok = acc_len > 0
        fixed[ok] = acc[broken][ok] / acc_len[ok, None]
        out[broken] = fixed  # still zero only for vertices no triangle uses
    return out


def _materials(path: Path, dicts: list[dict]) -> list[MeshMaterial]:
    """Convert assimp-py material dicts, keeping only colours the file really gives."""
    declared = _mtl_declarations(path) if path.suffix.lower() == ".obj" else None
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


_MTLLIB = re.compile(rb"^[ \t]*mtllib[ \t]+(.+?)[ \t]*\r?$", re.MULTILINE)


def _mtl_declarations(obj_path: Path) -> dict[str, set[str]]:
    """Map material name -> lower-cased MTL keywords it declares, for the OBJ's mtllib files.

    A regex over the raw bytes finds `mtllib` lines without splitting a 40 MB OBJ into lines.
    Missing or unreadable MTL files are simply absent (Assimp then uses its default material).
    """
    declared: dict[str, set[str]] = {}
    try:
        data = obj_path.read_bytes()
    except OSError:
        return declared
    for match in _MTLLIB.finditer(data):
        spec = match.group(1).decode("utf-8", "replace")
        # The spec allows several files per line; a single name with spaces is also common.
        candidates = [spec] if (obj_path.parent / spec).is_file() else spec.split()
        for name in candidates:
            mtl = obj_path.parent / name
            try:
                text = mtl.read_text(encoding="utf-8", errors="replace")
            except OSError:
                continue
            current: set[str] | None = None
            for line in text.splitlines():
                fields = line.split(None, 1)
                if not fields:
                    continue
                key = fields[0].lower()
                if key == "newmtl":
                    current = declared.setdefault(fields[1].strip() if len(fields) > 1 else "", set())
                elif current is not None:
                    current.add(key)
    return declared
