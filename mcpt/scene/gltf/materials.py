"""glTF metal-rough materials mapped onto mcpt's materials (mcpt/scene/materials.py).

What maps (README "glTF 2.0 scenes" has the full table):

* ``metallicFactor >= 0.5``: a ``conductor`` with Schlick's Fresnel whose F0 (mcpt's conductor
  ``albedo``) is the base colour, as glTF's metal BRDF has it (spec, appendix B.3.3); GGX
  ``roughness`` alpha = roughnessFactor^2, because glTF's roughness is perceptual (B.3.2:
  alpha = roughness^2). A factor strictly between 0 and 1 is rounded to metal or not (warned).
* otherwise: ``diffuse`` of the base colour. glTF's dielectric adds a specular layer (F0 = 0.04)
  that mcpt drops: a warning says so when roughnessFactor < 1, where that layer shows.
* ``baseColorTexture`` (sRGB) -> ``albedo_texture`` (with the factor ignored, warned, if it is not
  white); ``emissiveFactor`` x ``KHR_materials_emissive_strength`` -> ``emission``, the scale of
  ``emissiveTexture`` (sRGB) -> ``emission_texture`` (issue #22); ``doubleSided`` -> ``two_sided``.
* ``normalTexture`` (linear, tangent space, ``scale``) -> ``normal_map`` with MikkTSpace-style
  tangents from the UVs (mcpt/shading/normal_map.py); a TANGENT attribute is not read.
* ``alphaMode`` MASK (``alphaCutoff``) / BLEND -> ``opacity`` (+ ``opacity_cutoff`` for MASK):
  the base colour texture's alpha channel, else the factor's alpha; not on an emitter (warned).
* ignored with a warning: metallicRoughnessTexture, occlusionTexture, other material extensions.

A primitive without a material gets the spec's default material (section 3.9.6): white,
metallic 1, roughness 1, i.e. a rough white conductor.
"""

from __future__ import annotations

import logging

import numpy as np

from .container import Gltf, obj
from .images import texture
from .texture_transform import uv_of_khr_transform

log = logging.getLogger("mcpt")

#: Material extensions mapped here; any other is ignored with a warning.
KNOWN_EXTENSIONS = ("KHR_materials_emissive_strength",)
IGNORED_TEXTURES = ("metallicRoughnessTexture", "occlusionTexture")


def _factor(g: Gltf, obj: dict, key: str, default, where: str, n: int | None = None):
    value = obj.get(key, default)
    items = value if n is not None else [value]
    if (n is not None and (not isinstance(value, list) or len(value) != n)) or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and 0 <= x < float("inf") for x in items):
        raise g.error(where, f"{key} {value!r} is not {n or 1} finite number(s) >= 0"[:200])
    return np.asarray(value, np.float64) if n is not None else float(value)


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


def _warn_ignored(g: Gltf, m: dict, pbr: dict, base: np.ndarray, where: str) -> None:
    ignored = [k for k in IGNORED_TEXTURES if k in m or k in pbr]
    ignored += [f"extension {e}" for e in obj(m.get("extensions")) if e not in KNOWN_EXTENSIONS]
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
    metallic = _factor(g, pbr, "metallicFactor", 1.0, where)
    roughness = min(_factor(g, pbr, "roughnessFactor", 1.0, where), 1.0)
    out: dict = {"type": "conductor" if metallic >= 0.5 else "diffuse", "two_sided": m.get("doubleSided") is True}
    if "baseColorTexture" in pbr:
        out["albedo_texture"] = _texture_info(g, pbr["baseColorTexture"], where, "baseColorTexture")
        if (base[:3] != 1.0).any():
            log.warning("%s: %s: baseColorFactor %s times the texture: mcpt uses the texture alone",
                        g.path, where, base[:3].tolist())
    else:
        out["albedo"] = base[:3].tolist()
    if out["type"] == "conductor":
        out["roughness"] = roughness * roughness  # perceptual roughness -> GGX alpha (spec B.3.2)
    elif roughness < 1.0:
        log.warning("%s: %s: approximated as diffuse: glTF's dielectric specular layer (F0 0.04, "
                    "roughness %.3g) is dropped", g.path, where, roughness)
    if 0.0 < metallic < 1.0:
        log.warning("%s: %s: metallicFactor %.3g rounded to %s", g.path, where, metallic,
                    "metal (conductor)" if metallic >= 0.5 else "non-metal (diffuse)")
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
