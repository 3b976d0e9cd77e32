"""glTF ``KHR_lights_punctual`` -> mcpt's ``lights:`` (issue #20; the YAML side:
mcpt/scene/lights.py).

A light is placed by its node: at the node's world origin, shining along the node's local -Z
(the extension's convention). Units: glTF gives photometric intensities -- candela (lm sr^-1)
for point and spot lights, lux (lm m^-2) for directional ones -- and mcpt renders radiometric
ones (W sr^-1, W m^-2): both are divided by 683 lm/W, the luminous efficacy that defines the
candela (the convention of Blender's glTF exporter, which turns watts into candela by the same
factor). ``color`` multiplies the intensity. Spot cones: ``outerConeAngle`` (default pi/4) is
mcpt's (Mitsuba's) cutoff, ``innerConeAngle`` (default 0) its beam; glTF leaves the falloff
between them to the renderer (its sample code interpolates in cos), mcpt's is linear in angle.
``range`` (a cut-off distance the extension allows renderers to ignore) is ignored.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from .container import Gltf, obj

log = logging.getLogger("mcpt")

#: lm per W: a candela is 1/683 W sr^-1 at 540 THz (SI definition).
LM_PER_W = 683.0


def _number(g: Gltf, item: dict, key: str, default: float, where: str, lo=0.0, hi=math.inf) -> float:
    value = item.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (lo <= value <= hi):
        raise g.error(where, f"{key} must be a number in [{lo:g}, {hi:g}], got {value!r}"[:200])
    return float(value)


def _light(g: Gltf, li: int, world: np.ndarray, where: str) -> dict:
    defs = obj(obj(g.doc.get("extensions")).get("KHR_lights_punctual")).get("lights")
    defs = defs if isinstance(defs, list) else []
    if not (isinstance(li, int) and not isinstance(li, bool) and 0 <= li < len(defs)):
        raise g.error(where, f"KHR_lights_punctual light {li!r} does not exist ({len(defs)} lights)")
    item, at = obj(defs[li]), f"extensions.KHR_lights_punctual.lights[{li}]"
    kind = item.get("type")
    if kind not in ("point", "spot", "directional"):
        raise g.error(at, f"type {kind!r}: expected point, spot or directional")
    color = item.get("color", [1.0, 1.0, 1.0])
    if not (isinstance(color, list) and len(color) == 3
            and all(isinstance(c, (int, float)) and not isinstance(c, bool) and 0 <= c < math.inf for c in color)):
        raise g.error(at, f"color must be 3 numbers >= 0, got {color!r}"[:200])
    value = [c * _number(g, item, "intensity", 1.0, at) / LM_PER_W for c in color]
    axis = world[:3, :3] @ [0.0, 0.0, -1.0]
    if kind == "directional":
        return {"type": kind, "direction": axis.tolist(), "irradiance": value}
    out = {"type": kind, "position": world[:3, 3].tolist(), "intensity": value}
    if kind == "spot":
        spot = obj(item.get("spot"))
        outer = _number(g, spot, "outerConeAngle", math.pi / 4, at + ".spot", 0.0, math.pi / 2)
        inner = _number(g, spot, "innerConeAngle", 0.0, at + ".spot", 0.0, outer)
        if outer <= 0.0:
            raise g.error(at + ".spot", "outerConeAngle must be > 0")
        out.update(direction=axis.tolist(), cutoff_deg=math.degrees(outer), beam_deg=math.degrees(inner))
    return out


def lights(g: Gltf, placed) -> list[dict]:
    """The scene's ``lights:`` entries of the placed nodes (nodes.instances) that carry a light."""
    out = []
    for ni, world in placed:
        ref = obj(g.get("nodes", ni).get("extensions")).get("KHR_lights_punctual")
        if isinstance(ref, dict):
            out.append(_light(g, ref.get("light"), world, f"nodes[{ni}]"))
    return out
