"""The glTF node hierarchy flattened into world matrices (glTF 2.0 spec, section 3.5).

A node's local transform is its ``matrix`` (16 numbers, column-major) or its ``translation`` T,
``rotation`` R (unit quaternion x, y, z, w) and ``scale`` S, composed as T * R * S; a child's
world matrix is parent_world * child_local. :func:`instances` walks the scene's root nodes
depth first, in file order, and returns every node with its world matrix: meshes and cameras
are then placed by their node. The hierarchy must be a tree: a node reached twice (a cycle or two
parents) is one line naming it.
"""

from __future__ import annotations

import math

import numpy as np

from .container import Gltf


def _numbers(g: Gltf, node: dict, key: str, n: int, default, where: str) -> np.ndarray:
    value = node.get(key, default)
    ok = (isinstance(value, list) and len(value) == n
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value))
    if not ok:
        raise g.error(where, f"{key} must be {n} finite numbers, got {value!r}"[:200])
    return np.asarray(value, np.float64)


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """The 3x3 rotation of the unit quaternion ``q`` = (x, y, z, w) (normalised first)."""
    norm = float(np.linalg.norm(q))
    x, y, z, w = q / norm if norm > 0 else (0.0, 0.0, 0.0, 1.0)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def local_matrix(g: Gltf, index: int) -> np.ndarray:
    """The 4x4 local transform of node ``index``: its matrix, or T * R * S."""
    node = g.get("nodes", index)
    where = f"nodes[{index}]"
    if "matrix" in node:
        if any(k in node for k in ("translation", "rotation", "scale")):
            raise g.error(where, "matrix cannot be combined with translation/rotation/scale")
        m = _numbers(g, node, "matrix", 16, None, where).reshape(4, 4).T  # column-major in the file
        if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=1e-9):
            raise g.error(where, f"matrix is not affine (last row {m[3].tolist()})")
        m[3] = (0.0, 0.0, 0.0, 1.0)
        return m
    m = np.eye(4)
    rs = quaternion_matrix(_numbers(g, node, "rotation", 4, [0, 0, 0, 1], where))
    m[:3, :3] = rs * _numbers(g, node, "scale", 3, [1, 1, 1], where)  # R @ diag(S)
    m[:3, 3] = _numbers(g, node, "translation", 3, [0, 0, 0], where)
    return m


def roots(g: Gltf, scene: int | None = None) -> list[int]:
    """The root nodes of ``scene`` (default: the file's ``scene``, else scenes[0]; a file without
    scenes: every node that is nobody's child)."""
    scenes = g.items("scenes")
    if scene is None and scenes:
        scene = g.doc.get("scene", 0)
    if scene is not None:
        nodes = g.get("scenes", scene, "scene").get("nodes", [])
        if not isinstance(nodes, list):
            raise g.error(f"scenes[{scene}]", "nodes must be an array")
        return nodes
    children = {c for n in g.items("nodes") if isinstance(n, dict) for c in n.get("children", [])
                if isinstance(c, int)}
    return [i for i in range(len(g.items("nodes"))) if i not in children]


def instances(g: Gltf, scene: int | None = None) -> list[tuple[int, np.ndarray]]:
    """(node index, 4x4 world matrix) of every node of the scene, depth first in file order."""
    out: list[tuple[int, np.ndarray]] = []
    seen: set[int] = set()
    stack = [(i, np.eye(4), "scene") for i in reversed(roots(g, scene))]
    while stack:
        index, parent, where = stack.pop()
        g.get("nodes", index, where)
        if index in seen:
            raise g.error(f"nodes[{index}]", "reached twice: the node hierarchy must be a tree "
                                             "(a cycle, or a node with two parents)")
        seen.add(index)
        world = parent @ local_matrix(g, index)
        out.append((index, world))
        children = g.get("nodes", index).get("children", [])
        if not isinstance(children, list):
            raise g.error(f"nodes[{index}]", "children must be an array")
        stack.extend((c, world, f"nodes[{index}].children") for c in reversed(children))
    return out
