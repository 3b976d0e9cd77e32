"""A glTF camera as mcpt's pinhole or orthographic camera (glTF 2.0 spec, section 3.10).

A glTF camera looks down its node's -Z axis with +Y up; ``perspective.yfov`` is the full vertical
field of view in radians, ``aspectRatio`` (optional) width / height. mcpt's camera is a position,
a point looked at and an up hint, all taken from the node's world matrix (scale ignored: only
directions are used). glTF gives no image size: the resolution is ``--resolution`` or
:data:`DEFAULT_HEIGHT` pixels high and as wide as ``aspectRatio`` says (square without one). The
vertical field of view is kept whatever the resolution (a wider image sees more sideways).
"""

from __future__ import annotations

import math

import numpy as np

from .container import Gltf

#: Image height (pixels) when the command line gives no --resolution.
DEFAULT_HEIGHT = 512


def _name(item: dict) -> str | None:
    n = item.get("name")
    return n if isinstance(n, str) else None


def choose(g: Gltf, placed: list[tuple[int, np.ndarray]], name: str | None) -> tuple[int, np.ndarray]:
    """(node index, world matrix) of the camera to render: the first in the node hierarchy, or
    the one whose camera or node is called ``name``, or cameras[``name``] for a number."""
    nodes = [(i, w) for i, w in placed if "camera" in g.get("nodes", i)]
    if name is None:
        if not nodes:
            raise g.error("cameras", "no node places a camera: mcpt renders from the file's camera "
                                     "(place the glTF as a mesh in a YAML scene to choose one)")
        return nodes[0]
    names = []
    for i, w in nodes:
        ci = g.get("nodes", i)["camera"]
        cam = g.get("cameras", ci, f"nodes[{i}]")
        names += [n for n in (_name(cam), _name(g.get("nodes", i))) if n]
        if name in (_name(cam), _name(g.get("nodes", i)), str(ci)):
            return i, w
    known = ", ".join(repr(n) for n in dict.fromkeys(names)) or "none named"
    raise g.error("cameras", f"camera {name!r}: no such camera or camera node (cameras: {known})")


def camera(g: Gltf, node: int, world: np.ndarray) -> dict:
    """The mcpt camera data (YAML schema) of the camera on ``node`` with world matrix ``world``."""
    ci = g.get("nodes", node)["camera"]
    cam = g.get("cameras", ci, f"nodes[{node}]")
    where = f"cameras[{ci}]"
    if cam.get("type") == "orthographic":
        return {**_pose(g, node, world), **orthographic(g, cam, where)}
    if cam.get("type") != "perspective":
        raise g.error(where, f"type {cam.get('type')!r}: mcpt renders perspective and orthographic cameras")
    p = cam.get("perspective")
    if not isinstance(p, dict):
        raise g.error(where, "a perspective camera needs a perspective object")
    yfov = p.get("yfov")
    if isinstance(yfov, bool) or not isinstance(yfov, (int, float)) or not 0 < yfov < math.pi:
        raise g.error(where, f"perspective.yfov {yfov!r} is not an angle in (0, pi) radians")
    aspect = p.get("aspectRatio")
    if aspect is not None and (isinstance(aspect, bool) or not isinstance(aspect, (int, float))
                               or not 1e-3 <= aspect <= 1e3):
        raise g.error(where, f"perspective.aspectRatio {aspect!r} is not a number in [0.001, 1000]")
    height = DEFAULT_HEIGHT
    width = max(1, round(height * aspect)) if aspect else height
    return {**_pose(g, node, world), "vfov_deg": math.degrees(yfov), "resolution": [width, height]}


def _pose(g: Gltf, node: int, world: np.ndarray) -> dict:
    """position, look_at, up of the camera on ``node`` (looking down -Z, +Y up)."""
    linear = world[:3, :3]
    position = world[:3, 3]
    forward = linear @ (0.0, 0.0, -1.0)
    up = linear @ (0.0, 1.0, 0.0)
    length = float(np.linalg.norm(forward))
    if not length > 0 or not np.isfinite(world).all():
        raise g.error(f"nodes[{node}]", "the camera's world matrix has no view direction (zero scale)")
    return {"position": position.tolist(), "look_at": (position + forward / length).tolist(), "up": up.tolist()}


def orthographic(g: Gltf, cam: dict, where: str) -> dict:
    """An orthographic camera: ``xmag`` / ``ymag`` are the half width / height of the view (world
    units; glTF 2.0 section 5.14) -> ``ortho_height = 2 ymag``, the image as wide as xmag / ymag
    says (the node's scale is ignored, as for a perspective camera)."""
    o = cam.get("orthographic")
    if not isinstance(o, dict):
        raise g.error(where, "an orthographic camera needs an orthographic object")
    mags = []
    for key in ("xmag", "ymag"):
        v = o.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < 1e30:
            raise g.error(where, f"orthographic.{key} {v!r} is not a positive number")
        mags.append(float(v))
    aspect = mags[0] / mags[1]
    if not 1e-3 <= aspect <= 1e3:
        raise g.error(where, f"orthographic.xmag / ymag = {aspect:g} is not in [0.001, 1000]")
    height = DEFAULT_HEIGHT
    return {"projection": "orthographic", "ortho_height": 2.0 * mags[1],
            "resolution": [max(1, round(height * aspect)), height]}
