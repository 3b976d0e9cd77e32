"""Mitsuba 3 emitters that are not on a shape -> mcpt's ``lights:`` and ``environment:`` (issue #20;
the YAML side: mcpt/scene/lights.py).

* ``point``: ``position`` (or ``to_world``'s translation), ``intensity`` (default 1).
* ``spot``: ``to_world`` (the spot shines along its local +z), ``intensity`` (default 1),
  ``cutoff_angle`` (default 20 degrees), ``beam_width`` (default 3/4 of the cutoff).
* ``directional``: ``direction`` (or ``to_world``'s local +z), ``irradiance`` (default 1).
* ``constant``: ``radiance`` (default 1).
* ``envmap``: ``filename`` (relative to the XML file), ``scale`` (default 1), ``to_world``
  (a rotation); the map's orientation is Mitsuba's (mcpt/shading/envmap.py).

Parameters not listed are refused with their line (a texture as intensity, a medium).
"""

from __future__ import annotations

import numpy as np

from . import values as V
from .xmltree import Node, resolve_file

_KEYS = {"point": ("position", "intensity", "to_world"),
         "spot": ("intensity", "cutoff_angle", "beam_width", "to_world"),
         "directional": ("direction", "irradiance", "to_world"),
         "constant": ("radiance",),
         "envmap": ("filename", "scale", "to_world")}


def emitter(node: Node) -> tuple[str, dict]:
    """(``"lights"`` or ``"environment"``, the YAML data) of a top-level <emitter>."""
    kind = node.get("type")
    if kind not in _KEYS:
        raise node.error(f"not supported by mcpt (supported emitters: area on a shape, {', '.join(_KEYS)})")
    props = V.properties(node)
    for name, p in props.items():
        if name not in _KEYS[kind]:
            raise p.error(f"{name!r} is not a parameter of a {kind} emitter mcpt maps "
                          f"(mapped: {', '.join(_KEYS[kind])})")
    for child in node.children:
        if child.tag not in V.PROPERTY_TAGS:
            raise child.error(f"<{child.tag}> inside an emitter is not supported by mcpt")
    m = V.as_transform(props["to_world"]) if "to_world" in props else np.eye(4)
    colour = lambda name: list(V.as_color(props[name])) if name in props else [1.0, 1.0, 1.0]  # noqa: E731
    if kind == "constant":
        return "environment", {"radiance": colour("radiance")}
    if kind == "envmap":
        if "filename" not in props:
            raise node.error('missing <string name="filename">')
        env = {"file": str(resolve_file(node, V.as_string(props["filename"])))}
        if "scale" in props:
            env["scale"] = V.as_float(props["scale"])
        if "to_world" in props:
            env["transform"] = {"matrix": m.tolist()}
        return "environment", env
    if kind == "directional":
        d = V.as_point(props["direction"]) if "direction" in props else m[:3, :3] @ [0.0, 0.0, 1.0]
        return "lights", {"type": "directional", "direction": [float(x) for x in d], "irradiance": colour("irradiance")}
    pos = V.as_point(props["position"]) if "position" in props else m[:3, 3]
    light = {"type": kind, "position": [float(x) for x in pos], "intensity": colour("intensity")}
    if kind == "spot":
        cutoff = V.as_float(props["cutoff_angle"]) if "cutoff_angle" in props else 20.0
        beam = V.as_float(props["beam_width"]) if "beam_width" in props else 0.75 * cutoff
        light.update(direction=[float(x) for x in m[:3, :3] @ [0.0, 0.0, 1.0]], cutoff_deg=cutoff, beam_deg=beam)
    return "lights", light
