"""What a mesh's materials mean: the scene's material and the mesh file's own, resolved into rows of
the material table (mcpt/shading/materials.py) with the textures they read.

Two descriptions meet here, each turned into a :class:`MaterialRow` by its own function:

* the mesh file's materials (:func:`file_row`): what a reader found in the file, as
  ``MeshMaterial`` (mcpt/shapes/raw_mesh.py): an OBJ's MTL ``Kd`` / ``map_Kd`` / ``Ke`` /
  ``map_Ke`` today; a glTF material's baseColor / emissive factors and textures map onto the same
  fields. They describe a diffuse surface.
* the scene's material (:func:`scene_row`, a :class:`~mcpt.scene.materials.Material` from the YAML;
  a Mitsuba XML BSDF is meant to become one too): it wins key by key, and where it is silent
  the file's colours show through (:func:`albedo_from_file`; emission likewise).

A new format adds its mapping beside these two (a ``<format>_row`` function, or a conversion into
``Material`` / ``MeshMaterial``); :class:`MaterialResolver` keys, deduplicates and numbers the rows.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..shading import metalrough, roughplastic, specular_weights
from ..shading.materials import MaterialTable
from ..shading.texture import Texture, TextureError
from .materials import Material
from .model import Mesh, Scene
from .textures import (
    BumpMap,
    CheckerboardTexture,
    ImageTexture,
    NormalMap,
    build_bump_map,
    build_normal_map,
    build_texture,
    texture_key,
)

log = logging.getLogger("mcpt")

GLASS = ("dielectric", "roughdielectric", "thindielectric")  # no albedo
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)   # when neither the YAML nor the mesh file gives one
BLACK = (0.0, 0.0, 0.0)
RGB = tuple[float, float, float]


@dataclass(frozen=True)
class TextureRef:
    """Where a texture comes from: a YAML ImageTexture or an MTL ``map_Kd`` / ``map_Ke``."""

    file: Path
    wrap: str = "repeat"
    filter: str = "bilinear"
    linear: bool = False  # read c / 255 (an MTL map_d opacity, a metallic-roughness map), not sRGB-decoded
    uv: object = None     # the YAML texture's UV transform, if any


@dataclass(frozen=True)
class MaterialRow:
    """One row of the material table (column meanings: mcpt/shading/materials.py)."""

    name: str
    type: str
    albedo: RGB
    emission: RGB
    alpha: float = 0.0
    ior: float = 1.5
    texture: int = -1
    smooth: bool = False
    sigma_a: RGB = BLACK
    fresnel: str = "schlick"
    spec: RGB = (1.0, 1.0, 1.0)
    eta: RGB = (1.0, 1.0, 1.0)
    k: RGB = BLACK
    one_sided: bool = False
    normal_map: object = None  # the YAML NormalMap, then (texture id, scale, right_handed) (_add)
    opacity: object = None     # the YAML opacity texture and cutoff, then (texture id, cutoff) (_add)
    distribution: str = "ggx"
    masking: str = "height_correlated"
    nonlinear: bool = False
    metallic: float = 0.0
    metal_rough: object = None  # metalrough: the metallic-roughness TextureRef, then its texture id (_add)
    emission_texture: object = None  # the texture reference, then its id (_add); issue #22
    specular: float = 1.0      # metalrough: KHR_materials_specular's factor and colour (issue #21 item 5)
    specular_color: RGB = (1.0, 1.0, 1.0)
    spec_weights: object = None  # issue #22: (reflectance, transmittance), RGB or texture, then (rgb, id) (_add)
    roughness_texture: object = None  # issue #22: the roughness TextureRef, then its id (_add)


def absorption_sigma(ym: Material) -> RGB:
    """The absorption coefficient per unit length of a dielectric's ``absorption``.

    Beer-Lambert: light that travels d through the medium keeps exp(-sigma_a d) of itself
    (pbrt-v4, section 11.1.1), so the fraction ``color`` kept after ``distance`` gives
    sigma_a = -ln(color) / distance per channel."""
    if ym.absorption is None:
        return BLACK
    a = ym.absorption
    return tuple(-np.log(np.asarray(a.color, np.float64)) / a.distance)


def conductor_columns(ym: Material | None) -> dict:
    """The conductor's Fresnel columns of the table: mode, Schlick's lobe scale, complex index."""
    cols = {"fresnel": "schlick", "spec": (1.0, 1.0, 1.0), "eta": (1.0, 1.0, 1.0), "k": BLACK}
    if ym is None or ym.type != "conductor":
        return cols
    cols["fresnel"] = ym.fresnel_mode
    rgb = ym.specular_reflectance if isinstance(ym.specular_reflectance, tuple) else None
    if cols["fresnel"] == "schlick" and rgb is not None:
        cols["spec"] = rgb
    if cols["fresnel"] == "conductor":
        cols["eta"], cols["k"] = ym.complex_ior()
    return cols


def albedo_from_file(ym: Material | None) -> bool:
    """Whether the mesh file's Kd / map_Kd gives this YAML material its albedo (it is silent on it)."""
    if ym is None:
        return True
    if ym.albedo is not None or ym.albedo_texture is not None or ym.type in GLASS:
        return False
    return ym.type != "conductor" or ym.fresnel_mode == "schlick"


def file_row(name: str, kd: RGB, ke: RGB) -> MaterialRow:
    """A mesh file's material alone: a diffuse surface of reflectance ``kd`` emitting ``ke``."""
    return MaterialRow(name, "diffuse", kd, ke)


def scene_row(name: str, ym: Material, kd: RGB, ke: RGB) -> MaterialRow:
    """The scene's material ``ym``, the file's reflectance ``kd`` and emission ``ke`` where it is
    silent."""
    albedo = tuple(ym.albedo) if ym.albedo is not None else kd
    if ym.type in GLASS:
        albedo = (1.0, 1.0, 1.0)  # unused: glass has no albedo
    elif ym.type == "metalrough" and ym.albedo is None and ym.albedo_texture is not None:
        albedo = (1.0, 1.0, 1.0)  # the texture's factor (glsl/texture.glsl albedo_at)
    elif ym.type == "conductor" and ym.fresnel_mode != "schlick":
        # The albedo slot holds the lobe scale (specular_reflectance, texturable).
        rgb = ym.specular_reflectance
        albedo = tuple(rgb) if isinstance(rgb, tuple) else (1.0, 1.0, 1.0)
    emission = tuple(ym.emission) if ym.emission is not None else ke
    alpha, metallic = ym.alpha, 0.0
    if ym.type == "metalrough":  # glTF's perceptual roughness; glTF's defaults (1, 1) when absent
        alpha = metalrough.alpha(ym.roughness if "roughness" in ym.model_fields_set else 1.0)
        metallic = ym.metallic if ym.metallic is not None else 1.0
    mr = ym.metallic_roughness_texture
    if mr is not None:  # linear unless the scene says encoding: srgb (issue #22)
        mr = TextureRef(mr.file, mr.wrap, mr.filter, linear=mr.encoding != "srgb", uv=mr.uv)
    rt = ym.roughness_texture  # issue #22: read linearly unless the scene says srgb (Mitsuba's raw=false)
    rt = TextureRef(rt.file, rt.wrap, rt.filter, linear=rt.encoding == "linear", uv=rt.uv) if rt is not None else None
    if ym.emission_texture is not None:  # issue #22: emission scales the image (default 1)
        emission = tuple(ym.emission) if ym.emission is not None else (1.0, 1.0, 1.0)
    return MaterialRow(name, ym.type, albedo, emission, alpha=alpha, ior=ym.ior, metallic=metallic, metal_rough=mr,
                       smooth=bool(ym.smooth_normals), sigma_a=absorption_sigma(ym),
                       one_sided=not ym.two_sided, normal_map=ym.normal_map or ym.bump_map,
                       opacity=(ym.opacity, ym.opacity_cutoff) if ym.opacity is not None else None,
                       distribution=ym.distribution, masking=ym.masking, nonlinear=ym.nonlinear_mode,
                       emission_texture=ym.emission_texture, specular=ym.specular,
                       specular_color=tuple(ym.specular_color), spec_weights=specular_weights.column(ym),
                       roughness_texture=rt, **conductor_columns(ym))


class MaterialResolver:
    """The material table of a scene being loaded: rows keyed and numbered as the meshes come,
    and the textures they read (each image loaded once per wrap and filter)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.rows: list[MaterialRow] = []
        self.textures: list[Texture] = []
        self._index: dict = {}
        self._texture_index: dict = {}

    def yaml_material(self, spec: Mesh) -> Material | None:
        return self.scene.materials[spec.material] if spec.material is not None else None

    def needs_normals(self, spec: Mesh) -> bool:
        """Whether the mesh's material shades with vertex normals (read them)."""
        ym = self.yaml_material(spec)
        return bool(ym is not None and ym.smooth_normals)

    def needs_tangents(self, spec: Mesh) -> bool:
        """Whether the mesh's material has a normal map (tangents from its UVs)."""
        ym = self.yaml_material(spec)
        return bool(ym is not None and ym.normal_map is not None)

    def needs_uvs(self, spec: Mesh, file_materials) -> bool:
        """Whether some material of the mesh reads a texture (read UVs)."""
        ym = self.yaml_material(spec)
        if self._yaml_texture(spec) is not None or (ym is not None and (ym.normal_map or ym.bump_map or ym.opacity
                                                                         or ym.metallic_roughness_texture
                                                                         or ym.emission_texture
                                                                         or ym.roughness_texture)):
            return True
        if ym is not None and specular_weights.column(ym) is not None \
                and any(not isinstance(c, tuple) for c in specular_weights.column(ym)):  # issue #22
            return True
        if any(m.ke_map is not None for m in file_materials) and (ym is None or ym.emission is None):
            return True
        if any(m.d_map is not None for m in file_materials) and (ym is None or ym.opacity is None):
            return True
        return albedo_from_file(self.yaml_material(spec)) and any(m.kd_map is not None for m in file_materials)

    def mesh_ids(self, mi: int, spec: Mesh, file_materials) -> np.ndarray:
        """The table id of each of the mesh's file materials (``MeshMaterial``), rows added as needed."""
        ym = self.yaml_material(spec)
        mesh_where = self.scene.where("meshes", mi, "file")
        yaml_tex = self._yaml_texture(spec)
        from_file = albedo_from_file(ym)
        ids = np.empty(len(file_materials), np.int32)
        for j, mm in enumerate(file_materials):
            kd = tuple(mm.kd) if mm.kd is not None else DEFAULT_ALBEDO
            ke = tuple(mm.ke) if mm.ke is not None else BLACK
            kd_map = self._file_texture(mesh_where, spec, mm, mm.kd_map) if from_file else None
            ke_map = None
            if ym is None or (ym.emission is None and ym.emission_texture is None):
                ke_map = self._file_texture(mesh_where, spec, mm, mm.ke_map)
                ke = ke if ke_map is None or mm.ke is not None else (1.0, 1.0, 1.0)  # map_Ke x Ke
            tex, tex_where = yaml_tex if yaml_tex is not None else (
                kd_map, f"{mesh_where}: {spec.file}: material {mm.name!r}")
            tex_key = texture_key(tex) if tex is not None else None
            cut = self._file_opacity(mesh_where, spec, mm, ym, ke)
            if ym is None:
                key = ("mtl", str(spec.file), mm.name)
                row = replace(file_row(mm.name, kd, ke), opacity=cut, emission_texture=ke_map)
                ids[j] = self._add(key, row, tex, tex_where)
                continue
            # One row per YAML material, unless the file's colours show through it.
            full = not from_file and ym.emission is not None and cut is None
            key = (spec.material,) if full else (spec.material, kd, ke, tex_key, cut and texture_key(cut[0]),
                                                 ke_map and texture_key(ke_map))
            row = scene_row(spec.material, ym, kd, ke)
            row = replace(row, emission_texture=ke_map) if ke_map is not None else row
            ids[j] = self._add(key, replace(row, opacity=cut) if cut is not None else row, tex, tex_where)
        return ids

    def table(self) -> MaterialTable:
        rows = self.rows

        def rgb(attr):
            return np.asarray([getattr(r, attr) for r in rows], np.float64).reshape(-1, 3)

        def col(attr, dtype):
            return np.asarray([getattr(r, attr) for r in rows], dtype)

        return MaterialTable(tuple(r.name for r in rows), tuple(r.type for r in rows),
                             np.asarray([r.albedo for r in rows], np.float64),
                             np.asarray([r.emission for r in rows], np.float64),
                             alpha=col("alpha", np.float64), ior=col("ior", np.float64),
                             texture=col("texture", np.int64), smooth=col("smooth", bool),
                             sigma_a=rgb("sigma_a"), fresnel=tuple(r.fresnel for r in rows),
                             spec=rgb("spec"), eta=rgb("eta"), k=rgb("k"),
                             one_sided=col("one_sided", bool),
                             normal_map=tuple(r.normal_map for r in rows),
                             opacity=tuple(r.opacity for r in rows),
                             distribution=tuple(r.distribution for r in rows),
                             masking=tuple(r.masking for r in rows), nonlinear=col("nonlinear", bool),
                             coat=np.asarray([_coat(r) for r in rows]).reshape(-1, 65),
                             metallic=col("metallic", np.float64),
                             metal_rough=np.asarray([-1 if r.metal_rough is None else r.metal_rough for r in rows],
                                                    np.int64).reshape(-1),
                             emission_texture=np.asarray([-1 if r.emission_texture is None else r.emission_texture
                                                          for r in rows], np.int64).reshape(-1),
                             specular=col("specular", np.float64), specular_color=rgb("specular_color"),
                             spec_weights=tuple(r.spec_weights for r in rows),
                             roughness_texture=np.asarray([-1 if r.roughness_texture is None else r.roughness_texture
                                                           for r in rows], np.int64).reshape(-1))

    def _add(self, key, row: MaterialRow, tex, tex_where: str) -> int:
        """The id of the row ``key`` names, adding ``row`` (and its texture) the first time."""
        if key not in self._index:
            self._index[key] = len(self.rows)
            if tex is not None:
                t = self._texture_id(tex, tex_where)
                # The albedo column is informative only for a textured row: the shader reads texels
                # (a metal-rough row's is the texture's factor: glsl/texture.glsl albedo_at).
                mean = row.albedo if row.type == "metalrough" else tuple(self.textures[t].mean_linear())
                row = replace(row, texture=t, albedo=mean)
            if row.normal_map is not None:
                row = replace(row, normal_map=self._normal_map(row.name, row.normal_map))
            if row.emission_texture is not None:  # issue #22
                where = self.scene.where("materials", row.name, "emission_texture")
                row = replace(row, emission_texture=self._texture_id(row.emission_texture, where))
            if row.opacity is not None:
                ref, cutoff = row.opacity
                t = self._texture_id(ref, self.scene.where("materials", row.name, "opacity"))
                row = replace(row, opacity=(t, cutoff))
            if row.metal_rough is not None:
                where = self.scene.where("materials", row.name, "metallic_roughness_texture")
                row = replace(row, metal_rough=self._texture_id(row.metal_rough, where))
                self._check_metal_rough(row.metal_rough, where)
            if row.spec_weights is not None:  # issue #22
                row = replace(row, spec_weights=self._spec_weights(row.name, row.spec_weights))
            if row.roughness_texture is not None:  # issue #22
                where = self.scene.where("materials", row.name, "roughness_texture")
                row = replace(row, roughness_texture=self._texture_id(row.roughness_texture, where))
            self.rows.append(row)
        return self._index[key]

    def _check_metal_rough(self, t: int, where: str) -> None:
        """Refuse a grey metallic-roughness image (issue #21 item 1): glTF reads metalness from its
        blue and roughness from its green channel, so a grey map (1 or 2 channels, 8- or 16-bit)
        would set both from one value: almost surely a roughness-only or occlusion map."""
        tex = self.textures[t]
        if tex.channels < 3:
            kind = "grey" if tex.channels == 1 else "grey + alpha"
            raise TextureError(f"{where}: {tex.path}: a {kind} image ({tex.channels} channel"
                               f"{'s' if tex.channels > 1 else ''}); a metallic-roughness texture must be RGB or "
                               f"RGBA (glTF: metalness in blue, roughness in green): a grey one is almost "
                               f"surely a mistake (a roughness-only or occlusion map?)")

    def _spec_weights(self, name: str, pair) -> tuple:
        """The table's specular-weight column: ((rgb, texture id), (rgb, texture id)); a texture's
        rgb is its mean (informative, and a rough plastic's coat sampling weight, as Mitsuba's)."""
        out = []
        for key, value in zip(("specular_reflectance", "specular_transmittance"), pair):
            if isinstance(value, tuple):
                out.append((value, -1))
                continue
            t = self._texture_id(value, self.scene.where("materials", name, key))
            out.append((tuple(self.textures[t].mean_linear()), t))
        return tuple(out)

    def _normal_map(self, name: str, ref) -> tuple:
        """The table's normal-map column: (texture id, scale, right-handed frame, bump)."""
        bump = isinstance(ref, BumpMap)
        t = self._texture_id(ref, self.scene.where("materials", name, "bump_map" if bump else "normal_map"))
        return (t, ref.scale, not bump and ref.handedness == "right", bump)

    def _texture_id(self, ref, where: str) -> int:
        key = texture_key(ref)
        if key not in self._texture_index:
            try:
                texture = (build_normal_map(ref) if isinstance(ref, NormalMap) else
                           build_bump_map(ref) if isinstance(ref, BumpMap) else build_texture(ref))
            except TextureError as exc:  # name the scene line and key, not only the image
                raise TextureError(f"{where}: {exc}") from None
            self._texture_index[key] = len(self.textures)
            self.textures.append(texture)
        return self._texture_index[key]

    def _yaml_texture(self, spec: Mesh) -> tuple[ImageTexture, str] | None:
        """The YAML material's image (albedo_texture, or a conductor's specular_reflectance) and
        where the scene names it."""
        ym, name = self.yaml_material(spec), spec.material
        if ym is None:
            return None
        if ym.albedo_texture is not None:
            return ym.albedo_texture, self.scene.where("materials", name, "albedo_texture")
        if ym.type == "conductor" and isinstance(ym.specular_reflectance, (ImageTexture, CheckerboardTexture)):
            return ym.specular_reflectance, self.scene.where("materials", name, "specular_reflectance")
        return None

    def _file_opacity(self, mesh_where: str, spec: Mesh, mm, ym, ke) -> tuple | None:
        """A mesh file's ``map_d`` cut-out (stochastic opacity, read linearly) where the YAML gives
        no opacity and the material does not emit (an emitter cannot be cut out: warned)."""
        ref = self._file_texture(mesh_where, spec, mm, mm.d_map)
        if ref is None or (ym is not None and ym.opacity is not None):
            return None
        if max(ke) > 0 or (ym is not None and ym.emission is not None and max(ym.emission) > 0):
            log.warning("%s: material %r: map_d on an emitter is ignored (rendered opaque)", spec.file, mm.name)
            return None
        return (replace(ref, linear=True), None)

    @staticmethod
    def _file_texture(mesh_where: str, spec: Mesh, mm, tmap) -> TextureRef | None:
        """A mesh file's texture map as a reference; one line if the image is missing."""
        if tmap is None:
            return None
        if not tmap.file.is_file():
            raise TextureError(f"{mesh_where}: {spec.file}: material {mm.name!r} of {tmap.declared_in}: "
                               f"{tmap.keyword} texture not found: {tmap.file}")
        return TextureRef(tmap.file)


def _coat(row: MaterialRow) -> np.ndarray:
    """A rough plastic's coat tables (T at 64 cosines, then Fdr_int); zeros for other rows."""
    if row.type != "roughplastic":
        return np.zeros(65)
    table, fdr = roughplastic.tables(float(row.ior), float(row.alpha), row.distribution)
    return np.append(table, fdr)
