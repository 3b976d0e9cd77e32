"""The only road from scene data to render-ready objects.

``load_world(scene)`` reads every mesh (mcpt/mesh.py), resolves materials (YAML first, the OBJ's
MTL ``Kd``/``Ke`` where the YAML is silent), rebases the geometry relative to the camera in float64
before rounding to float32 (so a scene far from the origin keeps its precision near the camera),
builds the BVH (mcpt/bvh.py), reorders triangles into leaf order and derives the light table.
Nothing here touches GL: :mod:`mcpt.render` uploads what :meth:`World.buffers` returns.

Per-vertex data is read only where a material needs it (the data diet): vertex normals for meshes
whose material has ``smooth_normals`` (Assimp generates them when the file has none), UVs for
meshes whose material has an ``albedo_texture``; both are stored per triangle corner, in BVH
order, and uploaded only when the features ask for them:

    normals   1 RGBA32UI texel per triangle: the three corner normals, octahedral-encoded as two
              16-bit snorms each (error < 0.004 degrees), 4th component 0 (glsl/normals.glsl)
    uvs       2 texels per triangle: (u0, v0, u1, v1), (u2, v2, 0, 0) float bits (glsl/texture.glsl)
    textures  headers and sRGB texels of every albedo image (mcpt/textures.py)
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
from .mesh import first_of_duplicates, load_mesh
from .scene import Scene
from .textures import Texture, load_texture, pack_textures

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
    normals: np.ndarray | None = None   # (F, 3, 3) float32 unit corner normals (smooth materials)
    uvs: np.ndarray | None = None       # (F, 3, 2) float32 corner UVs (textured materials)
    textures: list = field(default_factory=list)  # [Texture], indexed by MaterialTable.texture

    @property
    def n_triangles(self) -> int:
        return int(self.tris.shape[0])

    def features(self, bounces: int | None = None, **flags) -> feat.Features:
        mt, ids = self.materials, self.tri_material
        used = {mt.types[i] for i in mt.used(ids)}
        return feat.derive(
            bounces=self.scene.render.bounces if bounces is None else bounces,
            n_triangles=self.n_triangles, n_emissive=self.lights.count, material_types=used,
            rough=mt.rough(ids), absorption=mt.absorbing(ids), textures=mt.textured(ids),
            smooth_normals=mt.smooth_shaded(ids), **{"bvh_dense": self.bvh.dense, **flags})

    def buffers(self, features: feat.Features) -> dict[str, np.ndarray]:
        """The arrays to upload, by TBO name: only what ``features`` needs (the data diet)."""
        out = {"tris": pack_triangles(self.tris, self.tri_material),
               "materials": self.materials.pack(
                   material_light_pdf_area(self.materials.emission, self.lights.total_power),
                   texels=features.material_texels)}
        if features.bvh:
            out["nodes"] = self.bvh.gpu_nodes(self.tris, dense=features.bvh_dense)
        if features.nee:
            out["lights"] = self.lights.pack()
        # The uber-shader (--features all) declares these buffers for any scene, but reads them
        # only for materials that have smooth normals / a texture: without such a material
        # nothing is read, so nothing is uploaded.
        if features.smooth_normals and self.normals is not None:
            out["normals"] = pack_normals(self.normals)
        if features.textures and self.textures:
            out["uvs"] = pack_uvs(self.uvs)
            out["textures"] = pack_textures(self.textures)
        return out


def octahedral_encode(n: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) -> uint32: octahedral map (Cigolle et al. 2014, JCGT 3(2)) with two
    16-bit snorms, x in the low half (GLSL unpackSnorm2x16)."""
    n = np.asarray(n, np.float64)
    p = n[..., :2] / np.maximum(np.abs(n).sum(axis=-1, keepdims=True), 1e-30)
    folded = (1.0 - np.abs(p[..., ::-1])) * np.where(p >= 0.0, 1.0, -1.0)
    p = np.where(n[..., 2:3] < 0.0, folded, p)
    q = np.round(np.clip(p, -1.0, 1.0) * 32767.0).astype(np.int32) & 0xFFFF
    return (q[..., 0] | (q[..., 1] << 16)).astype(np.uint32)


def octahedral_decode(v: np.ndarray) -> np.ndarray:
    """The inverse (float64), as glsl/normals.glsl computes it."""
    v = np.asarray(v, np.uint32)
    q = np.stack([v & 0xFFFF, v >> 16], axis=-1).astype(np.uint16).view(np.int16)
    p = np.maximum(q.astype(np.float64) / 32767.0, -1.0)
    n = np.concatenate([p, 1.0 - np.abs(p).sum(axis=-1, keepdims=True)], axis=-1)
    t = np.maximum(-n[..., 2:3], 0.0)
    n[..., :2] += np.where(n[..., :2] >= 0.0, -t, t)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def pack_normals(normals: np.ndarray) -> np.ndarray:
    """One RGBA32UI texel per triangle: the three corner normals octahedral-encoded, then 0."""
    out = np.zeros((normals.shape[0], 4), np.uint32)
    out[:, :3] = octahedral_encode(normals)
    return out


def pack_uvs(uvs: np.ndarray) -> np.ndarray:
    """Two RGBA32UI texels per triangle: (u0, v0, u1, v1), (u2, v2, 0, 0) as float bits."""
    f = uvs.shape[0]
    out = np.zeros((f, 8), np.float32)
    out[:, :6] = uvs.reshape(f, 6)
    return out.view(np.uint32).reshape(-1, 4)


def _first_of_duplicate_triangles(tris32: np.ndarray) -> np.ndarray:
    """Indices of the first occurrence of each triangle, equal float32 corners in the same cyclic
    order counting as the same triangle (what mesh.py does per file, here across files)."""
    corners = np.ascontiguousarray(tris32.reshape(-1, 3)).view(np.uint32)
    _, ids = np.unique(corners, axis=0, return_inverse=True)
    return first_of_duplicates(ids.reshape(-1, 3))


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
    cols: dict[str, list] = {k: [] for k in ("names", "types", "albedo", "emission", "alpha", "ior",
                                             "texture", "smooth", "sigma_a")}
    index: dict = {}
    textures: list[Texture] = []
    texture_index: dict = {}

    def texture_id(spec) -> int:
        key = (str(spec.file), spec.wrap, spec.filter)
        if key not in texture_index:
            texture_index[key] = len(textures)
            textures.append(load_texture(spec.file, spec.wrap, spec.filter))
        return texture_index[key]

    def material_id(key, name, mtype, kd, ke, ym=None):
        if key not in index:
            index[key] = len(cols["names"])
            tex = texture_id(ym.albedo_texture) if ym is not None and ym.albedo_texture else -1
            if tex >= 0:
                kd = tuple(textures[tex].mean_linear())  # informative only: the shader reads texels
            sigma = (0.0, 0.0, 0.0)
            if ym is not None and ym.absorption is not None:
                a = ym.absorption
                sigma = tuple(-np.log(np.asarray(a.color, np.float64)) / a.distance)
            for k, v in (("names", name), ("types", mtype), ("albedo", kd), ("emission", ke),
                         ("alpha", ym.roughness if ym else 0.0), ("ior", ym.ior if ym else 1.5),
                         ("texture", tex), ("smooth", bool(ym.smooth_normals) if ym else False),
                         ("sigma_a", sigma)):
                cols[k].append(v)
        return index[key]

    verts, mats, normals, uvs = [], [], [], []
    dropped = dropped_dup = 0
    for mi, spec in enumerate(scene.meshes):
        ym = scene.materials[spec.material] if spec.material is not None else None
        need_normals = bool(ym is not None and ym.smooth_normals)
        need_uvs = bool(ym is not None and ym.albedo_texture is not None)
        mesh = load_mesh(spec.file, spec.transform.matrix(), need_normals=need_normals,
                         need_uvs=need_uvs)
        dropped += mesh.dropped_degenerate
        dropped_dup += mesh.dropped_duplicate
        ids = np.empty(len(mesh.materials), np.int32)
        for k, mm in enumerate(mesh.materials):
            mtl_kd = tuple(mm.kd) if mm.kd is not None else DEFAULT_ALBEDO
            mtl_ke = tuple(mm.ke) if mm.ke is not None else (0.0, 0.0, 0.0)
            if ym is not None:
                has_albedo = ym.albedo is not None or ym.albedo_texture is not None or ym.type == "dielectric"
                kd = tuple(ym.albedo) if ym.albedo is not None else mtl_kd
                if ym.type == "dielectric":
                    kd = (1.0, 1.0, 1.0)  # unused: glass has no albedo
                ke = tuple(ym.emission) if ym.emission is not None else mtl_ke
                full = has_albedo and ym.emission is not None
                key = (spec.material,) if full else (spec.material, mtl_kd, mtl_ke)
                ids[k] = material_id(key, spec.material, ym.type, kd, ke, ym)
            else:
                ids[k] = material_id(("mtl", str(spec.file), mm.name), mm.name, "diffuse", mtl_kd, mtl_ke)
        # Rebase in float64 before the float32 rounding (issue #6: far-from-origin scenes).
        verts.append((mesh.vertices - origin)[mesh.faces])
        mats.append(ids[mesh.face_material])
        f = mesh.num_triangles
        normals.append(mesh.normals[mesh.faces] if mesh.normals is not None else None)
        if need_uvs and mesh.uvs is None:
            log.warning("%s: material %r has an albedo texture but the mesh has no UVs; "
                        "it reads texture coordinate (0, 0)", spec.file, spec.material)
        uvs.append(mesh.uvs[mesh.faces] if mesh.uvs is not None else np.zeros((f, 3, 2), np.float32))
    tris64 = np.concatenate(verts) if verts else np.zeros((0, 3, 3))
    tri_mat = np.concatenate(mats).astype(np.int32) if mats else np.zeros(0, np.int32)
    if tris64.shape[0] == 0:
        raise LoadError(f"{scene.source_path or 'scene'}: the scene has no triangles")
    t_load = time.perf_counter() - t0

    tris32 = tris64.astype(np.float32)
    keep = _first_of_duplicate_triangles(tris32) if len(scene.meshes) > 1 else slice(None)
    duplicates = 0 if isinstance(keep, slice) else int(tris32.shape[0] - keep.size)
    if duplicates:
        # The same surface twice (e.g. a light listed twice) would be two lights for NEE but one
        # surface for BSDF hits: direct light counted double. mesh.py does this within a file.
        log.info("dropped %d triangles repeated across mesh files", duplicates)
    tris32, tri_mat = tris32[keep], tri_mat[keep]
    bvh = build_bvh(tris32)
    tris32 = tris32[bvh.order]
    tri_mat = tri_mat[bvh.order]
    n_arr = uv_arr = None
    if any(n is not None for n in normals):
        n_arr = np.concatenate([n if n is not None else np.zeros((v.shape[0], 3, 3), np.float32)
                                for n, v in zip(normals, verts)]).astype(np.float32)[keep][bvh.order]
    if textures:
        uv_arr = np.concatenate(uvs).astype(np.float32)[keep][bvh.order]
    table = MaterialTable(tuple(cols["names"]), tuple(cols["types"]),
                          np.asarray(cols["albedo"], np.float64), np.asarray(cols["emission"], np.float64),
                          alpha=np.asarray(cols["alpha"], np.float64), ior=np.asarray(cols["ior"], np.float64),
                          texture=np.asarray(cols["texture"], np.int64),
                          smooth=np.asarray(cols["smooth"], bool),
                          sigma_a=np.asarray(cols["sigma_a"], np.float64).reshape(-1, 3))
    e1 = tris32[:, 1].astype(np.float64) - tris32[:, 0]
    e2 = tris32[:, 2].astype(np.float64) - tris32[:, 0]
    areas = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    lights = build_lights(areas, table.emission[tri_mat])
    if lights.count == 0:
        log.warning("%s: the scene has no emitters; the image will be black",
                    scene.source_path or "scene")
    stats = {"triangles": int(tris32.shape[0]), "dropped_degenerate": int(dropped),
             "dropped_duplicate": int(dropped_dup + duplicates),
             "materials": len(cols["names"]), "emissive_triangles": lights.count,
             "textures": len(textures), "load_seconds": t_load, "bvh": bvh.stats()}
    return World(scene, tris32, tri_mat, table, lights, bvh, stats, n_arr, uv_arr, textures)
