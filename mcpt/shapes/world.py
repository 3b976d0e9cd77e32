"""Building the world: the only road from a scene description to render-ready geometry.

``load_world(scene)`` reads every mesh (mcpt/shapes/mesh.py), resolves materials (YAML first, the OBJ's
MTL ``Kd`` / ``map_Kd`` / ``Ke`` / ``map_Ke`` where the YAML is silent; texture paths relative to the
MTL file), rebases the geometry relative to the camera in float64
before rounding to float32 (so a scene far from the origin keeps its precision near the camera),
builds the BVH (mcpt/shapes/bvh.py), reorders triangles into leaf order and derives the light
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
from ..scene import Scene
from ..shading.lights import Lights, build_lights
from ..shading.materials import MaterialTable
from ..shading.texture import Texture, TextureError, load_texture
from . import geometry, obj
from .bvh import BVH
from .bvh_build import build_bvh
from .dedup import first_of_duplicates
from .mesh import MeshError
from .sources import load_source  # issue #19: files, .serialized, primitives

log = logging.getLogger("mcpt")

DEFAULT_ALBEDO = (0.8, 0.8, 0.8)   # when neither the YAML nor the MTL gives one


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

    @property
    def n_triangles(self) -> int:
        return int(self.tris.shape[0])


def _first_of_duplicate_triangles(tris32: np.ndarray) -> np.ndarray:
    """Indices of the first occurrence of each triangle, equal float32 corners in the same cyclic
    order counting as the same triangle (what mesh.py does per file, here across files)."""
    corners = np.ascontiguousarray(tris32.reshape(-1, 3)).view(np.uint32)
    _, ids = np.unique(corners, axis=0, return_inverse=True)
    return first_of_duplicates(ids.reshape(-1, 3))


class _TextureRef:
    """Where a texture comes from: a YAML ImageTexture or an MTL ``map_Kd`` / ``map_Ke``."""

    def __init__(self, file, wrap: str = "repeat", filter: str = "bilinear"):
        self.file, self.wrap, self.filter = file, wrap, filter


def _albedo_from_mtl(ym) -> bool:
    """Whether the MTL's Kd / map_Kd gives this YAML material its albedo (it is silent on it)."""
    if ym is None:
        return True
    if ym.albedo is not None or ym.albedo_texture is not None or ym.type == "dielectric":
        return False
    return ym.type != "conductor" or ym.fresnel_mode == "schlick"


def _conductor_columns(ym) -> dict:
    """The conductor's Fresnel columns of the material table (mcpt/shading/materials.py)."""
    cols = {"fresnel": "schlick", "spec": (1.0, 1.0, 1.0), "eta": (1.0, 1.0, 1.0), "k": (0.0, 0.0, 0.0)}
    if ym is None or ym.type != "conductor":
        return cols
    cols["fresnel"] = ym.fresnel_mode
    rgb = ym.specular_reflectance if isinstance(ym.specular_reflectance, tuple) else None
    if cols["fresnel"] == "schlick" and rgb is not None:
        cols["spec"] = rgb
    if cols["fresnel"] == "conductor":
        cols["eta"], cols["k"] = ym.complex_ior()
    return cols


def _mtl_emission(mi, spec, mm, ke, ref):
    """MTL emission: ``Ke``, times the mean of ``map_Ke`` when there is one (Ke 1 if undeclared).
    Emission textures are not supported: the texture's mean keeps the emitted power, and a
    warning says so."""
    if ref is None:
        return ke
    mean = load_texture(ref.file).mean_linear()
    base = np.asarray(ke if mm.ke is not None else (1.0, 1.0, 1.0), np.float64)
    out = tuple(float(x) for x in base * mean)
    log.warning("%s: material %r: map_Ke %s: emission textures are not supported; it emits the "
                "texture's mean %s uniformly", spec.file, mm.name, ref.file,
                "(" + ", ".join(f"{x:.3g}" for x in out) + ")")
    return out


def load_world(scene: Scene) -> World:
    t0 = time.perf_counter()
    origin = np.asarray(scene.camera.position, np.float64)
    cols: dict[str, list] = {k: [] for k in ("names", "types", "albedo", "emission", "alpha", "ior",
                                             "texture", "smooth", "sigma_a", "fresnel", "spec", "eta",
                                             "k", "one_sided")}
    index: dict = {}
    textures: list[Texture] = []
    texture_index: dict = {}

    def texture_id(spec, where: str) -> int:
        key = (str(spec.file), spec.wrap, spec.filter)
        if key not in texture_index:
            try:
                texture = load_texture(spec.file, spec.wrap, spec.filter)
            except TextureError as exc:  # name the scene line and key, not only the image
                raise TextureError(f"{where}: {exc}") from None
            texture_index[key] = len(textures)
            textures.append(texture)
        return texture_index[key]

    def material_id(key, name, mtype, kd, ke, ym=None, tex_ref=None, tex_where=""):
        if key not in index:
            index[key] = len(cols["names"])
            tex = texture_id(tex_ref, tex_where) if tex_ref is not None else -1
            if tex >= 0:
                kd = tuple(textures[tex].mean_linear())  # informative only: the shader reads texels
            sigma = (0.0, 0.0, 0.0)
            if ym is not None and ym.absorption is not None:
                a = ym.absorption
                sigma = tuple(-np.log(np.asarray(a.color, np.float64)) / a.distance)
            for k, v in (("names", name), ("types", mtype), ("albedo", kd), ("emission", ke),
                         ("alpha", ym.roughness if ym else 0.0), ("ior", ym.ior if ym else 1.5),
                         ("texture", tex), ("smooth", bool(ym.smooth_normals) if ym else False),
                         ("sigma_a", sigma), ("one_sided", bool(ym is not None and not ym.two_sided)),
                         *_conductor_columns(ym).items()):
                cols[k].append(v)
        return index[key]

    def mtl_texture(mi, spec, mm_name, maps, key):
        """The MTL texture ``key`` (map_kd / map_ke) of material ``mm_name``; one line if missing."""
        if mm_name not in maps or key not in maps[mm_name]:
            return None
        mtl, file = maps[mm_name][key]
        if not file.is_file():
            raise TextureError(f"{scene.where('meshes', mi, 'file')}: {spec.file}: material {mm_name!r} "
                               f"of {mtl}: {key[:4]}{key[4:].capitalize()} texture not found: {file}")
        return _TextureRef(file)

    verts, mats, normals, uvs = [], [], [], []
    dropped = dropped_dup = 0
    for mi, spec in enumerate(scene.meshes):
        ym = scene.materials[spec.material] if spec.material is not None else None
        is_obj = spec.file is not None and spec.file.suffix.lower() == ".obj"  # issue #19: shapes
        maps = obj.mtl_textures(spec.file) if is_obj else {}
        need_normals = bool(ym is not None and ym.smooth_normals)
        yaml_tex = None
        if ym is not None and ym.albedo_texture is not None:
            yaml_tex = (ym.albedo_texture, scene.where('materials', spec.material, 'albedo_texture'))
        elif ym is not None and ym.type == "conductor" and not isinstance(ym.specular_reflectance, (tuple, type(None))):
            yaml_tex = (ym.specular_reflectance, scene.where('materials', spec.material, 'specular_reflectance'))
        mtl_albedo = _albedo_from_mtl(ym)
        need_uvs = yaml_tex is not None or (mtl_albedo and any("map_kd" in m for m in maps.values()))
        try:
            mesh = load_source(spec, spec.transform.matrix(), need_normals=need_normals,  # issue #19
                               need_uvs=need_uvs)
        except MeshError as exc:  # name the scene line and key too, not only the mesh file
            raise MeshError(f"{scene.where('meshes', mi, 'file')}: {exc}") from None
        dropped += mesh.dropped_degenerate
        dropped_dup += mesh.dropped_duplicate
        ids = np.empty(len(mesh.materials), np.int32)
        for k, mm in enumerate(mesh.materials):
            mtl_kd = tuple(mm.kd) if mm.kd is not None else DEFAULT_ALBEDO
            mtl_ke = tuple(mm.ke) if mm.ke is not None else (0.0, 0.0, 0.0)
            map_kd = mtl_texture(mi, spec, mm.name, maps, "map_kd") if mtl_albedo else None
            if ym is None or ym.emission is None:
                mtl_ke = _mtl_emission(mi, spec, mm, mtl_ke, mtl_texture(mi, spec, mm.name, maps, "map_ke"))
            tex_ref, tex_where = yaml_tex if yaml_tex is not None else (map_kd, f"{scene.where('meshes', mi, 'file')}: {spec.file}: material {mm.name!r}")
            tex_key = str(tex_ref.file) if tex_ref is not None else None
            if ym is not None:
                kd = tuple(ym.albedo) if ym.albedo is not None else mtl_kd
                if ym.type == "dielectric":
                    kd = (1.0, 1.0, 1.0)  # unused: glass has no albedo
                elif ym.type == "conductor" and ym.fresnel_mode != "schlick":
                    # The albedo slot holds the lobe scale (specular_reflectance, texturable).
                    rgb = ym.specular_reflectance
                    kd = tuple(rgb) if isinstance(rgb, tuple) else (1.0, 1.0, 1.0)
                ke = tuple(ym.emission) if ym.emission is not None else mtl_ke
                full = not mtl_albedo and ym.emission is not None
                key = (spec.material,) if full else (spec.material, mtl_kd, mtl_ke, tex_key)
                ids[k] = material_id(key, spec.material, ym.type, kd, ke, ym, tex_ref, tex_where)
            else:
                ids[k] = material_id(("mtl", str(spec.file), mm.name), mm.name, "diffuse", mtl_kd, mtl_ke,
                                     None, tex_ref, tex_where)
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
                          sigma_a=np.asarray(cols["sigma_a"], np.float64).reshape(-1, 3),
                          fresnel=tuple(cols["fresnel"]),
                          spec=np.asarray(cols["spec"], np.float64).reshape(-1, 3),
                          eta=np.asarray(cols["eta"], np.float64).reshape(-1, 3),
                          k=np.asarray(cols["k"], np.float64).reshape(-1, 3),
                          one_sided=np.asarray(cols["one_sided"], bool))
    lights = build_lights(geometry.areas(tris32), table.emission[tri_mat])
    if lights.count == 0:
        log.warning("%s: the scene has no emitters; the image will be black",
                    scene.source_path or "scene")
    stats = {"triangles": int(tris32.shape[0]), "dropped_degenerate": int(dropped),
             "dropped_duplicate": int(dropped_dup + duplicates),
             "materials": len(cols["names"]), "emissive_triangles": lights.count,
             "textures": len(textures), "load_seconds": t_load, "bvh": bvh.stats()}
    return World(scene, tris32, tri_mat, table, lights, bvh, stats, n_arr, uv_arr, textures)
