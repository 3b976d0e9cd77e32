"""The only road from scene data to render-ready objects.

``load_world(scene)`` reads every mesh (mcpt/mesh.py), resolves materials (YAML first, the OBJ's
MTL ``Kd``/``Ke`` where the YAML is silent), rebases the geometry relative to the camera in float64
before rounding to float32 (so a scene far from the origin keeps its precision near the camera),
builds the BVH (mcpt/bvh.py), reorders triangles into leaf order and derives the light table.
Nothing here touches GL: :mod:`mcpt.render` uploads what :meth:`World.buffers` returns.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from . import features as feat
from .bvh import BVH, build_bvh
from .lights import Lights, build_lights, material_light_pdf_area
from .materials import MaterialTable
from .mesh import load_mesh
from .scene import Scene

log = logging.getLogger("mcpt")

DEFAULT_ALBEDO = (0.8, 0.8, 0.8)   # when neither the YAML nor the MTL gives one


class LoadError(ValueError):
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

    @property
    def n_triangles(self) -> int:
        return int(self.tris.shape[0])

    def features(self, bounces: int | None = None, **flags) -> feat.Features:
        used = {self.materials.types[i] for i in np.unique(self.tri_material)}
        return feat.derive(
            bounces=self.scene.render.bounces if bounces is None else bounces,
            n_triangles=self.n_triangles, n_emissive=self.lights.count, material_types=used,
            **flags)

    def buffers(self, features: feat.Features) -> dict[str, np.ndarray]:
        """The arrays to upload, by TBO name: only what ``features`` needs (the data diet)."""
        out = {"tris": pack_triangles(self.tris, self.tri_material),
               "materials": self.materials.pack(
                   material_light_pdf_area(self.materials.emission, self.lights.total_power))}
        if features.bvh:
            out["nodes"] = self.bvh.gpu_nodes()
        if features.nee:
            out["lights"] = self.lights.pack()
        return out


def pack_triangles(tris: np.ndarray, tri_material: np.ndarray) -> np.ndarray:
    """Three RGBA32UI texels per triangle: (v0 bits, material), (v1 bits, 0), (v2 bits, 0)."""
    f = tris.shape[0]
    out = np.zeros((f, 3, 4), np.uint32)
    out[:, :, :3] = np.ascontiguousarray(tris, np.float32).view(np.uint32)
    out[:, 0, 3] = tri_material
    return out.reshape(-1, 4)


def load_world(scene: Scene) -> World:
    t0 = time.perf_counter()
    origin = np.asarray(scene.camera.position, np.float64)
    names: list[str] = []
    types: list[str] = []
    albedo: list = []
    emission: list = []
    index: dict = {}

    def material_id(key, name, mtype, kd, ke):
        if key not in index:
            index[key] = len(names)
            names.append(name)
            types.append(mtype)
            albedo.append(kd)
            emission.append(ke)
        return index[key]

    verts, mats = [], []
    dropped = 0
    for mi, spec in enumerate(scene.meshes):
        mesh = load_mesh(spec.file, spec.transform.matrix())
        dropped += mesh.dropped_degenerate
        ids = np.empty(len(mesh.materials), np.int32)
        for k, mm in enumerate(mesh.materials):
            mtl_kd = tuple(mm.kd) if mm.kd is not None else DEFAULT_ALBEDO
            mtl_ke = tuple(mm.ke) if mm.ke is not None else (0.0, 0.0, 0.0)
            if spec.material is not None:
                ym = scene.materials[spec.material]
                kd = tuple(ym.albedo) if ym.albedo is not None else mtl_kd
                ke = tuple(ym.emission) if ym.emission is not None else mtl_ke
                full = ym.albedo is not None and ym.emission is not None
                key = (spec.material,) if full else (spec.material, mtl_kd, mtl_ke)
                ids[k] = material_id(key, spec.material, ym.type, kd, ke)
            else:
                ids[k] = material_id(("mtl", str(spec.file), mm.name), mm.name, "diffuse", mtl_kd, mtl_ke)
        # Rebase in float64 before the float32 rounding (issue #6: far-from-origin scenes).
        verts.append((mesh.vertices - origin)[mesh.faces])
        mats.append(ids[mesh.face_material])
    tris64 = np.concatenate(verts) if verts else np.zeros((0, 3, 3))
    tri_mat = np.concatenate(mats).astype(np.int32) if mats else np.zeros(0, np.int32)
    if tris64.shape[0] == 0:
        raise LoadError(f"{scene.source_path or 'scene'}: the scene has no triangles")
    t_load = time.perf_counter() - t0

    tris32 = tris64.astype(np.float32)
    bvh = build_bvh(tris32)
    tris32 = tris32[bvh.order]
    tri_mat = tri_mat[bvh.order]
    table = MaterialTable(tuple(names), tuple(types), np.asarray(albedo, np.float64),
                          np.asarray(emission, np.float64))
    e1 = tris32[:, 1].astype(np.float64) - tris32[:, 0]
    e2 = tris32[:, 2].astype(np.float64) - tris32[:, 0]
    areas = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    lights = build_lights(areas, table.emission[tri_mat])
    if lights.count == 0:
        log.warning("%s: the scene has no emitters; the image will be black",
                    scene.source_path or "scene")
    stats = {"triangles": int(tris32.shape[0]), "dropped_degenerate": int(dropped),
             "materials": len(names), "emissive_triangles": lights.count,
             "load_seconds": t_load, "bvh": bvh.stats()}
    return World(scene, tris32, tri_mat, table, lights, bvh, stats)
