"""Building the world: the only road from a scene description to render-ready geometry.

``load_world(scene)`` is a sequence of named steps: read each mesh (mcpt/shapes/mesh.py), resolve
its materials (mcpt/scene/material_meaning.py: YAML first, the mesh file's MTL where the YAML is
silent), rebase it relative to the camera in float64 before rounding to float32 (so a scene far
from the origin keeps its precision near the camera), drop triangles repeated across files, build
the BVH (mcpt/shapes/bvh_build.py), reorder the triangles into leaf order and derive the light
table. Nothing here touches GL: mcpt/gpu/pack.py packs what the features need.

Per-vertex data is read only where a material needs it (the data diet): vertex normals for meshes
whose material has ``smooth_normals`` (Assimp generates them when the file has none), UVs for
meshes whose material has an ``albedo_texture``; both are stored per triangle corner, in BVH order.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import McptError
from ..parallel import ordered, row_chunks, side_by_side
from ..scene import Scene
from ..scene.material_meaning import MaterialResolver
from ..shading.emission_texture import triangle_powers
from ..shading.environment import env_power, load_environment
from ..shading.light_punctual import punctual_lights
from ..shading.lights import LUMINANCE, Lights, build_lights
from ..shading.materials import MaterialTable
from ..shading.normal_map import vertex_tangents
from . import geometry
from .bvh import BVH
from .bvh_build import build_bvh
from .dedup import first_of_repeated_corners
from .mesh import Mesh, MeshError, assemble, read_geometry
from .raw_mesh import MeshMaterial
from .rows import take_rows
from .sources import flipped, source_of
from .sphere import MAX_SPHERES, Sphere, pack_spheres, placed_sphere, sphere_bounds

log = logging.getLogger("mcpt")


class LoadError(McptError, ValueError):
    """The scene's data cannot be turned into a world (empty scene, ...)."""


@dataclass
class World:
    scene: Scene
    tris: np.ndarray           # (F, 3, 3) float32, camera-relative, BVH leaf order
    tri_material: np.ndarray   # (F,) int32 material id
    materials: MaterialTable
    lights: Lights
    bvh: BVH
    stats: dict = field(default_factory=dict)
    normals: np.ndarray | None = None   # (F, 3, 3) float32 unit corner normals (smooth materials)
    uvs: np.ndarray | None = None       # (F, 3, 2) float32 corner UVs (textured materials)
    textures: list = field(default_factory=list)  # [Texture], indexed by MaterialTable.texture
    tangents: np.ndarray | None = None  # (F, 3, 4) corner tangents + handedness (normal-mapped meshes)
    spheres: np.ndarray | None = None   # (TEXELS S, 4) uint32 analytic spheres (mcpt/shapes/sphere.py)
    sphere_material: np.ndarray | None = None  # (S,) int32 material id of each

    @property
    def n_triangles(self) -> int:
        return int(self.tris.shape[0])

    @property
    def n_spheres(self) -> int:
        return 0 if self.sphere_material is None else int(self.sphere_material.shape[0])

    @property
    def material_ids(self) -> np.ndarray:
        """The material id of every surface: each triangle's, then each analytic sphere's."""
        if not self.n_spheres:
            return self.tri_material
        return np.concatenate([self.tri_material, self.sphere_material]).astype(np.int32)


@dataclass
class MeshPart:
    """One mesh of the scene, read, its materials resolved, rebased to the camera.

    Attributes:
        tris: (F, 3, 3) float32 corner positions relative to the camera (rebased in float64).
        material: (F,) int32 material table id per triangle.
        normals: (F, 3, 3) float32 corner normals, or None (the material shades flat).
        uvs: (F, 3, 2) float32 corner UVs; zeros where the mesh has none or needs none.
        dropped_degenerate, dropped_duplicate: triangles the mesh lost while loading.
    """

    tris: np.ndarray
    material: np.ndarray
    normals: np.ndarray | None
    uvs: np.ndarray
    dropped_degenerate: int
    dropped_duplicate: int
    tangents: np.ndarray | None = None  # (F, 3, 4) corner tangents + handedness (normal maps)


def load_world(scene: Scene) -> World:
    """The render-ready world of ``scene``: read each mesh, resolve its materials and rebase it to
    the camera (:func:`_load_part`), drop triangles repeated across files, build the BVH, reorder
    the per-triangle data into its leaf order, derive the lights."""
    t0 = time.perf_counter()
    resolver = MaterialResolver(scene)
    parts, spheres, sphere_mi = [], [], []
    for mi in range(len(scene.meshes)):
        ball = _analytic_sphere(scene, mi, resolver) if len(spheres) < MAX_SPHERES else None
        if ball is not None:
            spheres.append(ball)
            sphere_mi.append(mi)
        else:
            parts.append(_load_part(scene, mi, resolver))
    if spheres and sum(len(p.tris) for p in parts) == 0:  # the triangle buffers are never empty
        parts += [_load_part(scene, mi, resolver) for mi in sphere_mi]
        spheres = []
    if sum(len(p.tris) for p in parts) == 0:
        raise LoadError(f"{scene.source_path or 'scene'}: the scene has no triangles")
    t_load = time.perf_counter() - t0

    tris, keep, repeated = _drop_repeated(np.concatenate([p.tris for p in parts]), len(parts))
    bvh = build_bvh(tris)
    # The worst subtree cost (the features ask for it: BVH.dense; now, so the set-up cache keeps
    # it) and the triangles in BVH order need nothing from each other: side by side.
    _, tris = side_by_side(bvh.worst_sah_cost, lambda: take_rows(tris, bvh.order))
    tri_mat, normals, uvs = _per_triangle(parts, bool(resolver.textures), keep, bvh.order)
    table = resolver.table()
    powers = None
    if any(table.emission_texture >= 0):  # issue #22: textured emitters picked by their real power
        powers = triangle_powers(geometry.areas(tris), tri_mat, uvs, table, resolver.textures)
    lights = _lights(scene, tris, bvh, table.emission[tri_mat], powers, [b for b, _ in spheres])
    if lights.entries == 0:
        log.warning("%s: the scene has no emitters; the image will be black",
                    scene.source_path or "scene")
    stats = {"triangles": int(tris.shape[0]),
             "dropped_degenerate": int(sum(p.dropped_degenerate for p in parts)),
             "dropped_duplicate": int(sum(p.dropped_duplicate for p in parts) + repeated),
             "spheres": len(spheres), "materials": len(table.names), "emissive_triangles": lights.count,
             "textures": len(resolver.textures), "load_seconds": t_load, "bvh": bvh.stats()}
    world = World(scene, tris, tri_mat, table, lights, bvh, stats, normals, uvs, resolver.textures,
                  _corner_tangents(parts, keep, bvh.order))
    if spheres:
        world.sphere_material = np.array([m for _, m in spheres], np.int32)
        world.spheres = pack_spheres([b for b, _ in spheres], world.sphere_material, scene.origin)
    return world


def _analytic_sphere(scene: Scene, mi: int, resolver: MaterialResolver) -> tuple[Sphere, int] | None:
    """(sphere, material id) when mesh ``mi`` is a ``shape: sphere`` that renders as an analytic
    sphere (mcpt/shapes/sphere.py says when), else None: the entry is tessellated."""
    spec = scene.meshes[mi]
    if spec.shape != "sphere":
        return None
    ball = placed_sphere(spec.transform.matrix(), spec.flip_normals)
    if ball is None:
        return None
    (mid,) = resolver.mesh_ids(mi, spec, [MeshMaterial("")])
    row = resolver.rows[int(mid)]
    if (any(row.emission) or row.emission_texture is not None or row.normal_map is not None
            or row.opacity is not None):
        return None
    return ball, int(mid)


def _lights(scene: Scene, tris: np.ndarray, bvh: BVH, tri_emission: np.ndarray, powers=None,
            balls: list[Sphere] = ()) -> Lights:
    """Emissive triangles, the scene's punctual lights and its environment (issue #20), in one
    table; positions relative to the camera like the triangles. The scene's bounding radius
    includes the analytic spheres ``balls``."""
    # The scene's box is the BVH root's: the min/max of the float32 corners, the same values as
    # tris.min(axis=0) over 3F corners, which cost 0.2 s at 10^6 triangles (issue #23).
    lo, hi = bvh.bounds_min[0], bvh.bounds_max[0]
    origin = np.asarray(scene.origin, np.float64)
    if balls:
        box = sphere_bounds(balls, origin)
        lo, hi = np.minimum(lo, box[0]), np.maximum(hi, box[1])
    radius = 0.5 * float(np.linalg.norm(hi.astype(np.float64) - lo))
    envmap = load_environment(scene.environment, scene.where("environment", "file"))
    if powers is None:
        # Only emitters' areas are read (a power is luminance x area): measured where the
        # luminance is not 0, the same values, 10^6 cross products fewer (issue #23). The powers
        # are then build_lights' own product, computed here once.
        luminance = tri_emission @ LUMINANCE
        areas = np.zeros(len(tris))
        lit = np.flatnonzero(luminance != 0.0)
        areas[lit] = geometry.areas(tris[lit])
        powers = luminance * areas
    else:
        areas = geometry.areas(tris)
    return build_lights(areas, tri_emission, punctual_lights(scene.lights, origin, radius),
                        env_power(scene.environment, envmap, radius), envmap, powers)


def _load_part(scene: Scene, mi: int, resolver: MaterialResolver) -> MeshPart:
    """Read mesh ``mi`` of the scene, resolve its materials, rebase it to the camera."""
    spec = scene.meshes[mi]
    need_normals = resolver.needs_normals(spec)
    try:
        raw = read_geometry(source_of(spec), need_normals=need_normals)
        if spec.flip_normals:
            raw = flipped(raw)
        need_uvs = resolver.needs_uvs(spec, raw.materials)
        mesh = assemble(raw, spec.transform.matrix(), need_normals=need_normals, need_uvs=need_uvs)
    except MeshError as exc:  # name the scene line and key too, not only the mesh file
        raise MeshError(f"{scene.where('meshes', mi, 'file')}: {exc}") from None
    ids = resolver.mesh_ids(mi, spec, mesh.materials)
    if need_uvs and mesh.uvs is None:
        log.warning("%s: material %r is textured but the mesh has no UVs; "
                    "its textures read texture coordinate (0, 0)", spec.file, spec.material)
    part = _rebased(mesh, ids, np.asarray(scene.origin, np.float64))
    if resolver.needs_tangents(spec) and mesh.uvs is not None:
        part.tangents = vertex_tangents(mesh.vertices, mesh.faces, mesh.uvs, mesh.normals)[mesh.faces]
    return part


def _rebased(mesh: Mesh, ids: np.ndarray, origin: np.ndarray) -> MeshPart:
    """The mesh's triangles relative to ``origin`` with their per-corner data."""
    # Rebase in float64 before the float32 rounding (issue #6: far-from-origin scenes); each
    # vertex is rounded once, before the corners are gathered (the same values as rounding the
    # (F, 3, 3) corners, at a third of the work: issue #23).
    verts = (mesh.vertices - origin).astype(np.float32)
    f = mesh.num_triangles
    tris = np.empty((f, 3, 3), np.float32)
    ordered(lambda rows: take_rows(verts, mesh.faces[rows], out=tris[rows]), row_chunks(f))  # a chunk per core
    normals = take_rows(mesh.normals, mesh.faces) if mesh.normals is not None else None
    uvs = take_rows(mesh.uvs, mesh.faces) if mesh.uvs is not None else np.zeros((f, 3, 2), np.float32)
    return MeshPart(tris, ids[mesh.face_material], normals, uvs, mesh.dropped_degenerate, mesh.dropped_duplicate)


def _drop_repeated(tris32: np.ndarray, n_meshes: int):
    """(kept triangles, their indices or a whole slice, how many were dropped): a triangle that
    repeats one of an earlier mesh file, equal float32 corners in the same cyclic order, is
    dropped (mesh.py does this within a file)."""
    if n_meshes < 2:
        return tris32, slice(None), 0
    keep = first_of_repeated_corners(tris32)
    repeated = int(tris32.shape[0] - keep.size)
    if not repeated:
        return tris32, slice(None), 0  # no copy of every triangle
    # The same surface twice (e.g. a light listed twice) would be two lights for NEE but one
    # surface for BSDF hits: direct light counted double.
    log.info("dropped %d triangles repeated across mesh files", repeated)
    return tris32[keep], keep, repeated


def _corner_tangents(parts: list[MeshPart], keep, order: np.ndarray) -> np.ndarray | None:
    """Corner tangents of the kept triangles in BVH order (zeros: none), if any mesh has them."""
    if all(p.tangents is None for p in parts):
        return None
    return take_rows(np.concatenate([p.tangents if p.tangents is not None else np.zeros((len(p.tris), 3, 4))
                                     for p in parts]).astype(np.float32)[keep], order)


def _per_triangle(parts: list[MeshPart], textured: bool, keep, order: np.ndarray):
    """Material ids, corner normals (if any material is smooth) and corner UVs (if any texture is
    read) of the kept triangles, in BVH order."""
    tri_mat = np.concatenate([p.material for p in parts]).astype(np.int32)[keep][order]
    normals = uvs = None
    if any(p.normals is not None for p in parts):
        corner = [p.normals if p.normals is not None else np.zeros((len(p.tris), 3, 3), np.float32) for p in parts]
        normals = take_rows(np.concatenate(corner).astype(np.float32)[keep], order)
    if textured:
        uvs = take_rows(np.concatenate([p.uvs for p in parts]).astype(np.float32)[keep], order)
    return tri_mat, normals, uvs
