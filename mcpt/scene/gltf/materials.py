"""glTF metal-rough materials mapped onto mcpt's materials (mcpt/scene/materials.py).

What maps (README "glTF 2.0 scenes" has the full table):

* ``pbrMetallicRoughness`` -> mcpt's ``metalrough`` (mcpt/shading/metalrough.py), the spec's
  appendix-B BRDF itself: ``baseColorFactor`` -> ``albedo``, ``metallicFactor`` -> ``metallic``,
  ``roughnessFactor`` -> ``roughness`` (perceptual, alpha = roughness^2 as B.3.2).
* ``baseColorTexture`` (sRGB) -> ``albedo_texture``, times the factor (``albedo``) as in glTF;
  ``metallicRoughnessTexture`` (linear; B: metalness, G: roughness) -> ``metallic_roughness_texture``,
  which scales the factors per texel.
* ``emissiveFactor`` x ``KHR_materials_emissive_strength`` -> ``emission``, the scale of
  ``emissiveTexture`` (sRGB) -> ``emission_texture`` (issue #22); ``doubleSided`` -> ``two_sided``.
* ``normalTexture`` (linear, tangent space, ``scale``) -> ``normal_map`` with MikkTSpace-style
  tangents from the UVs (mcpt/shading/normal_map.py); a TANGENT attribute is not read.
* ``alphaMode`` MASK (``alphaCutoff``) / BLEND -> ``opacity`` (+ ``opacity_cutoff`` for MASK):
  the base colour texture's alpha channel, else the factor's alpha; not on an emitter (warned).
* ``KHR_materials_ior`` (``ior``: >= 1, or 0) -> ``ior``; ``KHR_materials_specular``
  (``specularFactor`` in [0, 1], ``specularColorFactor`` >= 0) -> ``specular``, ``specular_color``
  (issue #21 item 5): the dielectric's Fresnel as the extensions define it. Their textures
  (``specularTexture``, ``specularColorTexture``) are not read: warned, the factors alone render.
* ignored with a warning: occlusionTexture, other material extensions (transmission, clearcoat, ...).

A primitive without a material gets the spec's default material (section 3.9.6): white,
metallic 1, roughness 1.
"""

from __future__ import annotations

import logging

import numpy as np

from .container import Gltf, obj
from .images import texture
from .texture_transform import uv_of_khr_transform

log = logging.getLogger("mcpt")

#: Material extensions mapped here; any other is ignored with a warning.
KNOWN_EXTENSIONS = ("KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_specular")
#: KHR_materials_specular's textures, which mcpt does not read (warned).
IGNORED_SPECULAR_TEXTURES = ("specularTexture", "specularColorTexture")
IGNORED_TEXTURES = ("occlusionTexture",)


def _factor(g: Gltf, obj: dict, key: str, default, where: str, n: int | None = None):
    value = obj.get(key, default)
    items = value if n is not None else [value]
    if (n is not None and (not isinstance(value, list) or len(value) != n)) or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and 0 <= x < float("inf") for x in items):
        raise g.error(where, f"{key} {value!r} is not {n or 1} finite number(s) >= 0"[:200])
    return np.asarray(value, np.float64) if n is not None else float(value)


def _unit(g: Gltf, obj: dict, key: str, default: float, where: str) -> float:
    """A factor the glTF schema bounds to [0, 1]: above 1 is refused, not clamped (issue #21 item 2:
    a clamped roughnessFactor 1.5 rendered as 1 without a word)."""
    value = _factor(g, obj, key, default, where)
    if value > 1.0:
        raise g.error(where, f"{key} {value:g} is not in [0, 1] (the glTF 2.0 schema's range)")
    return value


def _texture_info(g: Gltf, info, where: str, key: str) -> dict:
    if not isinstance(info, dict):
        raise g.error(where, f"{key} must be an object")
    if info.get("texCoord", 0) != 0:
        raise g.error(where, f"{key}.texCoord {info.get('texCoord')!r}: mcpt reads TEXCOORD_0 only")
    out = texture(g, info, f"{where}.{key}")
    ext = obj(info.get("extensions")).get("KHR_texture_transform")
    if ext is not None:
        out.update(uv_of_khr_transform(g, ext, f"{where}: {key}.extensions.KHR_texture_transform"))
    return out


def _opacity(g: Gltf, m: dict, pbr: dict, base: np.ndarray, where: str) -> dict:
    """alphaMode MASK (alphaCutoff, default 0.5) / BLEND (stochastic) -> ``opacity``: the base
    colour texture's alpha, else the factor's alpha (a one-colour checkerboard)."""
    mode = m.get("alphaMode", "OPAQUE")
    if mode not in ("MASK", "BLEND"):
        return {}
    if "baseColorTexture" in pbr:
        opacity = {**_texture_info(g, pbr["baseColorTexture"], where, "baseColorTexture"), "channel": "alpha"}
        if base[3] != 1.0:
            log.warning("%s: %s: baseColorFactor alpha %.3g times the texture's: mcpt uses the texture's "
                        "alpha alone", g.path, where, base[3])
    else:
        opacity = {"type": "checkerboard", "color0": [float(base[3])] * 3, "color1": [float(base[3])] * 3}
    out = {"opacity": opacity}
    if mode == "MASK":
        out["opacity_cutoff"] = min(_factor(g, m, "alphaCutoff", 0.5, where), 1.0)
    return out


def _normal_map(g: Gltf, info, where: str) -> dict:
    """normalTexture -> mcpt's ``normal_map`` (glTF's tangent frame: MikkTSpace, ``uv``)."""
    out = _texture_info(g, info, where, "normalTexture")
    out["scale"] = _factor(g, info, "scale", 1.0, f"{where}: normalTexture")
    return out


def _emission(g: Gltf, m: dict, where: str) -> tuple[list[float] | None, dict | None]:
    """emissiveFactor x emissiveStrength, and the emissiveTexture it scales (issue #22) or None."""
    emissive = _factor(g, m, "emissiveFactor", [0.0, 0.0, 0.0], where, 3)
    ext = obj(m.get("extensions")).get("KHR_materials_emissive_strength")
    if isinstance(ext, dict):
        emissive = emissive * _factor(g, ext, "emissiveStrength", 1.0, where)
    if not emissive.any():
        return None, None
    tex = _texture_info(g, m["emissiveTexture"], where, "emissiveTexture") if "emissiveTexture" in m else None
    return emissive.tolist(), tex


def _ior_specular(g: Gltf, m: dict, where: str) -> dict:
    """KHR_materials_ior and KHR_materials_specular -> ``ior``, ``specular``, ``specular_color``
    (only those given: absent ones keep the defaults, so a plain material compiles as before)."""
    exts, out = obj(m.get("extensions")), {}
    if "KHR_materials_ior" in exts:
        ext = exts["KHR_materials_ior"]
        if not isinstance(ext, dict):
            raise g.error(where, "extensions.KHR_materials_ior must be an object")
        ior = ext.get("ior", 1.5)
        if not (isinstance(ior, (int, float)) and not isinstance(ior, bool) and (ior == 0 or 1 <= ior < float("inf"))):
            raise g.error(where, f"KHR_materials_ior.ior {ior!r} is not >= 1 or 0 (the extension's range; 0: "
                                 f"Fresnel 1, the specular-glossiness conversion)"[:200])
        out["ior"] = float(ior)
    if "KHR_materials_specular" in exts:
        ext = exts["KHR_materials_specular"]
        if not isinstance(ext, dict):
            raise g.error(where, "extensions.KHR_materials_specular must be an object")
        at = f"{where}: KHR_materials_specular"
        out["specular"] = _unit(g, ext, "specularFactor", 1.0, at)
        out["specular_color"] = _factor(g, ext, "specularColorFactor", [1.0, 1.0, 1.0], at, 3).tolist()
    return out


def _warn_ignored(g: Gltf, m: dict, pbr: dict, base: np.ndarray, where: str) -> None:
    ignored = [k for k in IGNORED_TEXTURES if k in m or k in pbr]
    ignored += [f"extension {e}" for e in obj(m.get("extensions")) if e not in KNOWN_EXTENSIONS]
    spec = obj(obj(m.get("extensions")).get("KHR_materials_specular"))
    ignored += [f"KHR_materials_specular.{k} (its factor alone is used)" for k in IGNORED_SPECULAR_TEXTURES
                if k in spec]
    mode = m.get("alphaMode", "OPAQUE")
    if mode not in ("OPAQUE", "MASK", "BLEND"):
        ignored.append(f"alphaMode {mode} (rendered opaque)")
    if ignored:
        log.warning("%s: %s: ignored by mcpt: %s", g.path, where, ", ".join(ignored))


def material_name(g: Gltf, index: int | None) -> str:
    """The name of glTF material ``index`` (None: the default material) for mcpt."""
    if index is None:
        return "gltf_default"
    name = g.get("materials", index).get("name")
    return name if isinstance(name, str) and name else f"material_{index}"


def material(g: Gltf, index: int | None) -> dict:
    """The mcpt material data (YAML schema) of glTF material ``index`` (None: the default)."""
    m = {} if index is None else g.get("materials", index, "primitive material")
    where = "default material" if index is None else f"materials[{index}]"
    if isinstance(m.get("name"), str):
        where += f" {m['name']!r}"
    pbr = m.get("pbrMetallicRoughness", {})
    if not isinstance(pbr, dict):
        raise g.error(where, "pbrMetallicRoughness must be an object")
    base = _factor(g, pbr, "baseColorFactor", [1.0, 1.0, 1.0, 1.0], where, 4)
    if (base > 1.0).any():
        raise g.error(where, f"baseColorFactor {base.tolist()} is not in [0, 1]")
    metallic = _unit(g, pbr, "metallicFactor", 1.0, where)
    roughness = _unit(g, pbr, "roughnessFactor", 1.0, where)
    out: dict = {"type": "metalrough", "albedo": base[:3].tolist(), "metallic": metallic,
                 "roughness": roughness, "two_sided": m.get("doubleSided") is True}
    out.update(_ior_specular(g, m, where))
    if "baseColorTexture" in pbr:  # times the factor (glsl/texture.glsl albedo_at)
        out["albedo_texture"] = _texture_info(g, pbr["baseColorTexture"], where, "baseColorTexture")
    if "metallicRoughnessTexture" in pbr:  # B metalness, G roughness, per texel (glsl/texture.glsl)
        out["metallic_roughness_texture"] = _texture_info(g, pbr["metallicRoughnessTexture"], where,
                                                          "metallicRoughnessTexture")
    if "normalTexture" in m:
        out["normal_map"] = _normal_map(g, m["normalTexture"], where)
    emission, emission_texture = _emission(g, m, where)
    if emission is not None:
        out["emission"] = emission
    if emission_texture is not None:
        out["emission_texture"] = emission_texture
    cut = _opacity(g, m, pbr, base, where)
    if cut and emission is not None and max(emission) > 0:
        log.warning("%s: %s: alphaMode %s on an emitter is ignored (rendered opaque: light sampling "
                    "needs its area)", g.path, where, m.get("alphaMode"))
    else:
        out.update(cut)
    _warn_ignored(g, m, pbr, base, where)
    return out
