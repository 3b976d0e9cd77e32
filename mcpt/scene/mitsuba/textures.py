"""Mitsuba 3 textures -> mcpt textures: ``bitmap`` (an image) and ``checkerboard``, each with its
``to_uv`` transform (mcpt/scene/textures.py).

Mitsuba's UVs have v pointing DOWN the image (v = 0 is its top row) and mcpt's point up: a mesh's
mcpt UV is F(uv) = (u, 1 - v) of Mitsuba's (mcpt/shapes/primitives.py). So a ``to_uv`` A becomes
F A F for a bitmap (the image rows are flipped too, so the same texel is read) and A F for a
checkerboard (its squares are computed on Mitsuba's own transformed coordinates, so color0 and
color1 land where Mitsuba puts them). A ``to_uv`` given as a 4x4 transform keeps rows 0-1 and
columns 0, 1, 3 (the 2-D affine part, as Mitsuba's ``Transform4f::extract``); a 3x3 ``matrix``
is used as it is.
"""

from __future__ import annotations

import numpy as np

from ..fields import TEXTURE_SUFFIXES
from . import values as V
from .xmltree import Node, deref, resolve_file

SUPPORTED = ("bitmap", "checkerboard")

#: Mitsuba's UVs -> mcpt's: (u, v) -> (u, 1 - v), as a 3x3 homogeneous matrix (its own inverse).
FLIP = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])


def _to_uv(node: Node) -> np.ndarray:
    """The 3x3 homogeneous 2-D transform of a ``to_uv`` <transform>."""
    ops = node.children
    if len(ops) == 1 and ops[0].tag == "matrix":
        v = V.floats(ops[0], ops[0].need("value"))
        if len(v) == 9:
            return np.reshape(v, (3, 3))
    m = V.as_transform(node)
    out = np.eye(3)
    out[:2, :2], out[:2, 2] = m[:2, :2], m[:2, 3]
    return out


def _uv(props: dict[str, Node], checkerboard: bool) -> dict:
    """``{"uv": {"matrix": ...}}`` in mcpt's convention, or nothing for no / an identity to_uv."""
    if "to_uv" not in props:
        return {}
    a = _to_uv(props["to_uv"])
    if abs(np.linalg.det(a[:2, :2])) < 1e-12:
        raise props["to_uv"].error("to_uv flattens the texture (its 2-D part is singular)")
    m = a @ FLIP if checkerboard else FLIP @ a @ FLIP
    if np.allclose(m, np.eye(3), rtol=0.0, atol=1e-12):
        return {}
    return {"uv": {"matrix": [[float(x) for x in row] for row in m[:2]]}}


def _colour(props: dict[str, Node], node: Node, key: str, default: float) -> list[float]:
    for child in node.children:
        if child.tag in ("texture", "ref") and child.get("name") == key:
            raise child.error(f"a texture as the checkerboard's {key} is not supported by mcpt "
                              "(give a colour)")
    rgb = V.as_color(props[key]) if key in props else (default,) * 3
    if not all(0.0 <= c <= 1.0 for c in rgb):
        raise props[key].error(f"{key} {rgb} out of [0, 1]: mcpt takes reflectances only")
    return list(rgb)


def _checkerboard(node: Node, props: dict[str, Node]) -> dict:
    return {"type": "checkerboard", "color0": _colour(props, node, "color0", 0.4),
            "color1": _colour(props, node, "color1", 0.2), **_uv(props, checkerboard=True)}


def normal_map(bsdf: Node, ids: dict[str, Node], nested_material) -> dict:
    """A ``normalmap`` BSDF: its nested BSDF's material (``nested_material(node)``) with
    ``normal_map`` set. The map must be a ``bitmap`` with ``raw=true`` (Mitsuba sRGB-decodes one
    without, which no normal map means); Mitsuba's frame: B = N x T (``handedness: right``)."""
    maps = [c for c in bsdf.children if c.tag in ("texture", "ref") and c.get("name") == "normalmap"]
    inner = [c for c in bsdf.children if c.tag in ("bsdf", "ref") and c not in maps]
    if len(maps) != 1 or len(inner) != 1:
        raise bsdf.error("a normalmap needs one <texture name=\"normalmap\"> and one nested BSDF")
    tex = deref(maps[0], ids)
    if tex.tag != "texture":
        raise maps[0].error(f"expected a texture, got <{tex.tag}>")
    props = V.properties(tex)
    if tex.get("type") != "bitmap" or "raw" not in props or not V.as_bool(props["raw"]):
        raise tex.error("a normal map must be a bitmap with raw=true (mcpt reads normal maps linearly)")
    out = nested_material(inner[0])
    out["normal_map"] = {**texture(tex, raw=True), "handedness": "right"}
    return out


def mask(bsdf: Node, ids: dict[str, Node], nested_material) -> dict:
    """A ``mask`` BSDF: its nested BSDF's material with ``opacity`` set (stochastic: Mitsuba
    blends with a null BSDF). ``opacity`` a bitmap, a checkerboard (Mitsuba reads opacities with
    eval_1, whose checkerboard puts color1 where eval puts color0: the colours are swapped here)
    or a number (a checkerboard of one colour)."""
    props = V.properties(bsdf)
    maps = [c for c in bsdf.children if c.tag in ("texture", "ref") and c.get("name") == "opacity"]
    inner = [c for c in bsdf.children if c.tag in ("bsdf", "ref") and c not in maps]
    if len(inner) != 1:
        raise bsdf.error("a mask needs one nested BSDF")
    if maps:
        tex = deref(maps[0], ids)
        if tex.tag != "texture":
            raise maps[0].error(f"expected a texture, got <{tex.tag}>")
        opacity = texture(tex)
        if opacity.get("type") == "checkerboard":
            opacity["color0"], opacity["color1"] = opacity["color1"], opacity["color0"]
    else:
        a = V.as_float(props["opacity"]) if "opacity" in props else 0.5
        if not 0.0 <= a <= 1.0:
            raise props["opacity"].error(f"opacity {a} out of [0, 1]")
        opacity = {"type": "checkerboard", "color0": [a] * 3, "color1": [a] * 3}
    out = nested_material(inner[0])
    out["opacity"] = opacity
    return out


def bump_map(bsdf: Node, ids: dict[str, Node], nested_material) -> dict:
    """A ``bumpmap`` BSDF: its nested BSDF's material with ``bump_map`` set: one nested bitmap
    (bilinear, no ``to_uv``), ``scale`` (default 1); ``raw`` picks linear or sRGB heights."""
    maps = [c for c in bsdf.children if c.tag in ("texture", "ref") and deref(c, ids).tag == "texture"]
    inner = [c for c in bsdf.children if c.tag in ("bsdf", "ref") and c not in maps]
    if len(maps) != 1 or len(inner) != 1:
        raise bsdf.error("a bumpmap needs one nested texture and one nested BSDF")
    tex = deref(maps[0], ids)
    props = V.properties(tex)
    if tex.get("type") != "bitmap":
        raise tex.error("a bump map must be a bitmap in mcpt")
    for key, bad in (("to_uv", None), ("filter_type", "nearest")):
        if key in props and (bad is None or V.as_string(props[key]) == bad):
            raise props[key].error(f"{key} on a bump map is not supported by mcpt")
    data = texture(tex, raw=True)
    out = nested_material(inner[0])
    bprops = V.properties(bsdf)
    out["bump_map"] = {"file": data["file"], "wrap": data.get("wrap", "repeat"),
                       "scale": V.as_float(bprops["scale"]) if "scale" in bprops else 1.0,
                       "encoding": "linear" if "raw" in props and V.as_bool(props["raw"]) else "srgb"}
    return out


def texture(node: Node, raw: bool = False) -> dict:
    """A ``<texture>`` as mcpt's texture data (``albedo_texture``); one located error if refused.
    A bitmap's 8-bit images are sRGB-decoded, which is what Mitsuba does with ``raw=false`` (the
    default) for PNG/JPEG; ``raw=true``: ``encoding: linear`` (issue #22; a normal or bump map's
    ``raw`` is read by its caller)."""
    kind = node.get("type")
    if kind not in SUPPORTED:
        raise node.error(f"not supported by mcpt (supported textures: {', '.join(SUPPORTED)})")
    props = V.properties(node)
    if kind == "checkerboard":
        return _checkerboard(node, props)
    if "filename" not in props:
        raise node.error("a bitmap needs a filename (in-memory bitmaps cannot come from a file)")
    path = resolve_file(node, V.as_string(props["filename"]))
    if path.suffix.lower() not in TEXTURE_SUFFIXES:
        raise props["filename"].error(f"{path.suffix or '(none)'} images are not supported by mcpt "
                                      f"(formats: {', '.join(TEXTURE_SUFFIXES)})")
    out: dict = {"file": str(path), **_uv(props, checkerboard=False)}
    if not raw and "raw" in props:  # Mitsuba's raw: no sRGB decoding of 8-bit values
        out["encoding"] = "linear" if V.as_bool(props["raw"]) else "srgb"
    if "wrap_mode" in props:
        wrap = V.as_string(props["wrap_mode"])
        if wrap not in ("repeat", "mirror", "clamp"):
            raise props["wrap_mode"].error(f"wrap_mode {wrap!r}: expected repeat, mirror or clamp")
        out["wrap"] = wrap
    if "filter_type" in props:
        kind = V.as_string(props["filter_type"])
        if kind not in ("bilinear", "nearest"):
            raise props["filter_type"].error(f"filter_type {kind!r}: expected bilinear or nearest")
        out["filter"] = kind
    return out


def emitter_texture(emitter: Node, ids: dict[str, Node]) -> dict | None:
    """An area emitter's ``radiance`` given as a texture (issue #22): mcpt's ``emission_texture``
    (its emission then a scale of 1), or None for a colour."""
    for child in emitter.children:
        if child.tag in ("texture", "ref") and child.get("name", "radiance") == "radiance":
            target = deref(child, ids)
            if target.tag != "texture":
                raise child.error(f"expected a texture, got <{target.tag}>")
            return texture(target)
    return None


def alpha_texture(bsdf: Node, ids: dict[str, Node], props: dict[str, Node]) -> dict:
    """A rough BSDF's ``<texture name="alpha">`` (issue #22) as ``roughness_texture`` (roughness then
    absent: 1, the texture is alpha), or nothing. Mitsuba 3's roughconductor and roughdielectric read
    alpha with the texture's eval_1: a bitmap sRGB-decoded unless ``raw=true`` (Mitsuba's Bitmap marks
    every PNG sRGB, grey and 16-bit ones too; verified: a grey 128 PNG evaluates to 0.2159), so
    ``encoding: srgb`` without raw. eval_1 of a colour image is its luminance, mcpt reads the first
    channel: a colour image is refused. roughplastic's alpha is a number in Mitsuba 3 too."""
    maps = [c for c in bsdf.children if c.tag in ("texture", "ref") and c.get("name") in ("alpha", "alpha_u",
                                                                                            "alpha_v")]
    if not maps:
        return {}
    child = maps[0]
    if child.get("name") != "alpha":
        raise child.error("an alpha_u / alpha_v texture (anisotropic roughness) is not supported by mcpt")
    if bsdf.get("type") == "roughplastic":
        raise child.error("a roughplastic's alpha is a number (Mitsuba 3 reads it as one; its coat tables "
                          "are computed for one alpha)")
    if "alpha" in props:
        raise child.error(f"alpha given twice (first on line {props['alpha'].line})")
    tex = deref(child, ids)
    if tex.tag != "texture" or tex.get("type") != "bitmap":
        raise child.error("an alpha texture must be a bitmap in mcpt")
    tprops = V.properties(tex)
    raw = "raw" in tprops and V.as_bool(tprops["raw"])
    data = texture(tex, raw=True)
    _refuse_colour(tex, data["file"])
    return {"roughness_texture": {**data, "encoding": "linear" if raw else "srgb"}}


def _refuse_colour(tex: Node, file: str) -> None:
    """One located line for a colour (not grey) image as alpha (a missing one: the loader says so)."""
    import cv2

    img = cv2.imread(file, cv2.IMREAD_UNCHANGED)
    if img is None or img.ndim == 2 or img.shape[2] < 3:
        return
    if not (np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 1], img[..., 2])):
        raise tex.error("a colour image as alpha: Mitsuba reads its luminance, mcpt its first channel "
                        "(give a grey image)")
