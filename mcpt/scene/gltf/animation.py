"""glTF 2.0 node animation (spec section 3.11) -> an mcpt ``animation:`` (issue #26).

The file's first animation is read: each channel animates a node's ``translation``, ``rotation``
or ``scale`` through a LINEAR sampler (times in seconds, the ``input`` accessor; values, the
``output``). A node whose primitives become scene meshes gets one mesh track per
primitive: its keys are the channels' keys grouped by time (frame = seconds x 24, the scene's
fps 24), a channel the node does not animate held at its rest value, and the track's ``parent``
is the node's parent's world matrix, so a frame's placement is ``parent_world * T(t) R(t) S(t)``,
the spec's composition; LINEAR is the spec's lerp and slerp, which mcpt's ``linear``
interpolation is (mcpt/scene/keyframes.py). The mesh's ``transform`` stays the rest pose (a
still without --frames).

Refused in one line naming the channel or sampler: STEP and CUBICSPLINE samplers, morph-target
``weights``, an animated node that places no mesh (a camera, a light, a parent of other nodes:
their children would need the whole hierarchy re-evaluated per frame), an animated node under an
animated ancestor, times that do not increase.
"""

from __future__ import annotations

import math

import numpy as np

from . import accessors
from .container import Gltf

PATHS = {"translation": ("translate", 3), "rotation": ("rotate", 4), "scale": ("scale", 3)}
DEFAULT_FPS = 24.0


def _channels(g: Gltf) -> dict:
    """node -> {path: (times, values)} of the first animation's channels."""
    anim = g.get("animations", 0)
    samplers = anim.get("samplers", [])
    out: dict = {}
    for ci, ch in enumerate(anim.get("channels", [])):
        where = f"animations[0].channels[{ci}]"
        target = ch.get("target", {}) if isinstance(ch, dict) else {}
        node, path = target.get("node"), target.get("path")
        if path not in PATHS:
            raise g.error(where, f"target.path {path!r} is not supported (translation, rotation, scale)")
        if not isinstance(node, int):
            raise g.error(where, "target.node must be a node index")
        g.get("nodes", node, where)
        si = ch.get("sampler")
        if not isinstance(si, int) or not 0 <= si < len(samplers):
            raise g.error(where, f"sampler {si!r} is not one of the animation's {len(samplers)}")
        s = samplers[si]
        swhere = f"animations[0].samplers[{si}]"
        if s.get("interpolation", "LINEAR") != "LINEAR":
            raise g.error(swhere, f"interpolation {s.get('interpolation')} is not supported (LINEAR)")
        times = accessors.read(g, s.get("input"), swhere).reshape(-1).astype(np.float64)
        values = accessors.read(g, s.get("output"), swhere).astype(np.float64)
        if values.shape != (len(times), PATHS[path][1]) or not np.all(np.isfinite(values)):
            raise g.error(swhere, f"output must be {len(times)} finite {path} values")
        if len(times) == 0 or not np.all(np.diff(times) > 0) or not np.all(np.isfinite(times)):
            raise g.error(swhere, "input times must be finite and strictly increasing")
        out.setdefault(node, {})[path] = (times, values)
    return out


def _parents(g: Gltf) -> dict:
    return {c: i for i, n in enumerate(g.items("nodes")) if isinstance(n, dict)
            for c in n.get("children", []) if isinstance(c, int)}


def _keys(g: Gltf, node: int, channels: dict, fps: float) -> list:
    """The node's keys by time: each sets the channels with a key then; static ones at the first."""
    rest = g.get("nodes", node)
    by_time: dict = {}
    for path, (times, values) in channels.items():
        for t, v in zip(times, values):
            by_time.setdefault(float(t), {})[PATHS[path][0]] = [float(x) for x in v]
    first = min(by_time)
    for path, (name, _width) in PATHS.items():
        if path not in channels:
            default = [0, 0, 0, 1] if path == "rotation" else ([1, 1, 1] if path == "scale" else [0, 0, 0])
            by_time[first][name] = [float(x) for x in rest.get(path, default)]
    return [{"frame": t * fps, **v} for t, v in sorted(by_time.items())]


def animation_data(g: Gltf, placed, owners: list, fps: float = DEFAULT_FPS) -> dict | None:
    """The scene's ``animation:`` data for the glTF file (None if it has no animation); scene
    mesh entry i was placed by node ``owners[i]``."""
    if not g.items("animations"):
        return None
    channels = _channels(g)
    if not channels:
        return None
    parents, world = _parents(g), dict(placed)
    tracks, span = [], []
    for node, chans in sorted(channels.items()):
        where = f"nodes[{node}]"
        entries = [i for i, o in enumerate(owners) if o == node]
        if not entries:
            raise g.error(where, "is animated but places no mesh: only mesh nodes can be animated")
        if "matrix" in g.get("nodes", node):
            raise g.error(where, "is animated but has a matrix (glTF animates TRS nodes only)")
        up = parents.get(node)
        while up is not None:
            if up in channels:
                raise g.error(where, f"is animated under animated nodes[{up}]: not supported")
            up = parents.get(up)
        parent = world[parents[node]] if node in parents and parents[node] in world else np.eye(4)
        keys = _keys(g, node, chans, fps)
        span += [keys[0]["frame"], keys[-1]["frame"]]
        tracks += [{"mesh": i, "interpolation": "linear", "keys": keys,
                    "parent": {"matrix": parent.tolist()}} for i in entries]
    if not tracks:
        return None
    return {"fps": fps, "frames": [max(0, math.floor(min(span))), max(0, math.ceil(max(span)))],
            "meshes": tracks}
