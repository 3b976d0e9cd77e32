"""Mitsuba 3 BSDFs -> mcpt materials (the same mapping a YAML ``materials:`` entry gives).

Supported: ``diffuse``, ``conductor``, ``roughconductor`` (GGX or Beckmann, with Mitsuba 3's
separable Smith masking term), ``dielectric``, ``roughdielectric`` (likewise), ``thindielectric``,
``plastic``, ``roughplastic`` (both ``nonlinear`` modes, exactly), ``twosided`` (one BSDF for both
sides). A bare Mitsuba BSDF is ONE-sided (its back is black): it becomes ``two_sided: false``;
``twosided`` makes it ``two_sided: true``. Colours may be ``<rgb>``, ``<spectrum>``, a number, or
(diffuse reflectance, plastic diffuse_reflectance, the glasses' and plastics' ``specular_reflectance``
and ``specular_transmittance``, issue #22) a ``bitmap`` or ``checkerboard`` texture
(mcpt/scene/mitsuba/textures.py). A roughconductor's or roughdielectric's ``alpha`` may be a grey
``bitmap`` (issue #22: ``roughness_texture``, sRGB-decoded as Mitsuba does unless ``raw=true``).
"""

from __future__ import annotations

import logging

from ...shading.roughdielectric import MIN_ALPHA as ROUGH_GLASS_MIN_ALPHA
from . import values as V
from .conductors import MITSUBA_CONDUCTORS
from .textures import alpha_texture, bump_map, mask, normal_map, texture
from .xmltree import Node, deref

log = logging.getLogger("mcpt")

SUPPORTED = ("diffuse", "conductor", "roughconductor", "dielectric", "roughdielectric", "thindielectric",
             "plastic", "roughplastic", "twosided",
             "normalmap", "bumpmap", "mask")  # the last three: mcpt/scene/mitsuba/textures.py

#: Mitsuba's named indices of refraction (its data/ior table: the ones a scene is likely to name).
IOR = {"vacuum": 1.0, "helium": 1.00004, "hydrogen": 1.00013, "air": 1.000277,
       "carbon dioxide": 1.00045, "water": 1.333, "acetone": 1.36, "ethanol": 1.361,
       "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501, "silicone oil": 1.52045,
       "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.47,
       "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
       "amber": 1.55, "pet": 1.575, "diamond": 2.419}
#: |ext_ior - 1| below this counts as air (Mitsuba's default ext_ior is air, 1.000277).
AIR_TOLERANCE = 1e-3


def _ior(props: dict[str, Node], key: str, default: str) -> float:
    node = props.get(key)
    if node is None:
        return IOR[default]
    if node.tag == "string":
        name = V.as_string(node).lower()
        if name not in IOR:
            raise node.error(f"unknown index of refraction {name!r} (known: {', '.join(IOR)})")
        return IOR[name]
    return V.as_float(node)


def _relative_ior(props: dict[str, Node], node: Node, int_default: str) -> float:
    """int_ior / ext_ior; mcpt's outside is air, so an ext_ior other than ~1 warns."""
    int_ior = _ior(props, "int_ior", int_default)
    ext_ior = _ior(props, "ext_ior", "air")
    if abs(ext_ior - 1.0) > AIR_TOLERANCE:
        log.warning("%s:%d: %s: ext_ior %.4g: mcpt's outside is air, so the interface uses the "
                    "ratio int_ior/ext_ior = %.4g (exact for this interface alone)",
                    node.file, node.line, node.label, ext_ior, int_ior / ext_ior)
    return int_ior / ext_ior


def _albedo(bsdf: Node, props, key, default, ids) -> dict:
    """The albedo of a diffuse or plastic: a colour property, or a nested/referenced texture."""
    for child in bsdf.children:
        if child.tag in ("texture", "ref") and child.get("name", key) == key:
            target = deref(child, ids)
            if target.tag != "texture":
                raise child.error(f"expected a texture, got <{target.tag}>")
            return {"albedo_texture": texture(target)}
    node = props.get(key)
    rgb = V.as_color(node) if node is not None else (default,) * 3
    if not all(0.0 <= c <= 1.0 for c in rgb):
        raise node.error(f"{key} {rgb} out of [0, 1]: mcpt takes reflectances only")
    return {"albedo": list(rgb)}


def _weights(bsdf: Node, props: dict[str, Node], ids, *keys: str) -> dict:
    """Mitsuba's ``specular_reflectance`` / ``specular_transmittance`` factors (issue #22,
    mcpt/shading/specular_weights.py): a colour in [0, 1] or a nested/referenced texture (a bitmap
    is sRGB-decoded, as Mitsuba's raw=false); absent keys stay absent (Mitsuba's 1)."""
    out: dict = {}
    for key in keys:
        if key in props or any(c.tag in ("texture", "ref") and c.get("name", "") == key for c in bsdf.children):
            value = _albedo(bsdf, props, key, 1.0, ids)
            out[key] = value.get("albedo", value.get("albedo_texture"))
    return out


def _conductor(bsdf: Node, props: dict[str, Node]) -> dict:
    out: dict = {"type": "conductor"}
    if "eta" in props or "k" in props:
        if "material" in props:
            raise bsdf.error("give material or eta and k, not both")
        out["eta"] = list(V.as_color(props["eta"])) if "eta" in props else [0.0] * 3
        out["k"] = list(V.as_color(props["k"])) if "k" in props else [1.0] * 3
        out["fresnel"] = "conductor"
    else:
        name = V.as_string(props["material"]) if "material" in props else "none"
        if name == "none":
            out["fresnel"] = "none"
        elif name in MITSUBA_CONDUCTORS:
            # Mitsuba's own RGB reduction of the preset (conductors.py), not mcpt's metal: presets.
            eta, k = MITSUBA_CONDUCTORS[name]
            out.update(eta=list(eta), k=list(k), fresnel="conductor")
        else:
            raise props["material"].error(f"conductor material {name!r} is not among Mitsuba 3's "
                                          f"presets (none, {', '.join(MITSUBA_CONDUCTORS)})")
    if "specular_reflectance" in props:
        out["specular_reflectance"] = list(V.as_color(props["specular_reflectance"]))
    return out


def _rough(bsdf: Node, props: dict[str, Node], ids: dict[str, Node]) -> dict:
    """The microfacet keys of a rough BSDF: alpha (a number, or a bitmap: ``roughness_texture``,
    mcpt/scene/mitsuba/textures.py alpha_texture), Mitsuba's distribution (Beckmann by default) and
    its separable masking term G1(wi) G1(wo) (include/mitsuba/render/microfacet.h). ``sample_visible``
    changes only how directions are drawn (the variance), not the image: accepted and ignored."""
    textured = alpha_texture(bsdf, ids, props)
    dist = V.as_string(props["distribution"]) if "distribution" in props else "beckmann"
    if dist not in ("ggx", "beckmann"):
        raise props["distribution"].error(f"distribution {dist!r}: expected ggx or beckmann")
    if "alpha_u" in props or "alpha_v" in props:
        au = V.as_float(props.get("alpha_u") or props["alpha_v"])
        av = V.as_float(props.get("alpha_v") or props["alpha_u"])
        if au != av:
            raise (props.get("alpha_u") or bsdf).error("anisotropic roughness (alpha_u != alpha_v) is "
                                                       "not supported by mcpt")
        alpha = au
    else:
        alpha = V.as_float(props["alpha"]) if "alpha" in props else 0.1
    if not 0.0 <= alpha <= 1.0:
        raise (props.get("alpha") or bsdf).error(f"alpha {alpha} out of [0, 1]")
    if textured:  # issue #22: the texture is alpha (roughness absent: 1)
        return {**textured, "distribution": dist, "masking": "separable"}
    return {"roughness": alpha, "distribution": dist, "masking": "separable"}


def material(bsdf: Node, ids: dict[str, Node], two_sided: bool = False) -> dict:
    """The mcpt material dict of a ``<bsdf>`` (a ref followed); one located error if refused."""
    bsdf = deref(bsdf, ids)
    if bsdf.tag != "bsdf":
        raise bsdf.error("expected a <bsdf>")
    kind = bsdf.get("type")
    props = V.properties(bsdf)
    if kind == "twosided":
        inner = [c for c in bsdf.children if c.tag in ("bsdf", "ref")]
        if len(inner) != 1:
            raise bsdf.error("a twosided with a different BSDF per side is not supported by mcpt "
                             "(give one nested BSDF)")
        return material(inner[0], ids, two_sided=True)
    if kind == "normalmap":  # a wrapper: mcpt/scene/mitsuba/textures.py
        return normal_map(bsdf, ids, lambda node: material(node, ids, two_sided))
    if kind == "mask":
        return mask(bsdf, ids, lambda node: material(node, ids, two_sided))
    if kind == "bumpmap":
        return bump_map(bsdf, ids, lambda node: material(node, ids, two_sided))
    if kind == "diffuse":
        out = {"type": "diffuse", **_albedo(bsdf, props, "reflectance", 0.5, ids)}
    elif kind in ("conductor", "roughconductor"):
        out = _conductor(bsdf, props)
        if kind == "roughconductor":
            out.update(_rough(bsdf, props, ids))
    elif kind in ("dielectric", "roughdielectric", "thindielectric"):
        weights = _weights(bsdf, props, ids, "specular_reflectance", "specular_transmittance")
        ior = _relative_ior(props, bsdf, "bk7")
        if not 1.0 < ior <= 4.0:
            raise bsdf.error(f"relative index {ior:.4g} outside mcpt's range (1, 4] (the denser medium "
                             "must be inside; 1 is no interface)")
        if kind != "roughdielectric":
            return {"type": kind, "ior": ior, **weights}
        rough = _rough(bsdf, props, ids)
        if rough.get("roughness", 1.0) < ROUGH_GLASS_MIN_ALPHA:
            raise (props.get("alpha") or bsdf).error(f"alpha {rough['roughness']:g} below mcpt's least "
                                                     f"rough-glass alpha {ROUGH_GLASS_MIN_ALPHA:g} (use a dielectric)")
        return {"type": "roughdielectric", "ior": ior, **rough, **weights}
    elif kind == "plastic":
        ior = _relative_ior(props, bsdf, "polypropylene")
        out = {"type": "plastic", "ior": ior, **_albedo(bsdf, props, "diffuse_reflectance", 0.5, ids),
               **_weights(bsdf, props, ids, "specular_reflectance"),
               "nonlinear": V.as_bool(props["nonlinear"]) if "nonlinear" in props else False}
    elif kind == "roughplastic":
        weights = _weights(bsdf, props, ids, "specular_reflectance")
        ior = _relative_ior(props, bsdf, "polypropylene")
        if not 1.0 < ior <= 4.0:
            raise bsdf.error(f"relative index {ior:.4g} outside mcpt's range (1, 4] (the coat must be denser)")
        rough = _rough(bsdf, props, ids)
        if rough["roughness"] < ROUGH_GLASS_MIN_ALPHA:
            raise (props.get("alpha") or bsdf).error(f"alpha {rough['roughness']:g} below mcpt's least alpha "
                                                     f"{ROUGH_GLASS_MIN_ALPHA:g} (use a plastic)")
        out = {"type": "roughplastic", "ior": ior, **rough, **_albedo(bsdf, props, "diffuse_reflectance", 0.5, ids),
               "nonlinear": V.as_bool(props["nonlinear"]) if "nonlinear" in props else False, **weights}
    else:
        raise bsdf.error(f"not supported by mcpt (supported: {', '.join(SUPPORTED)})")
    out["two_sided"] = two_sided
    return out
