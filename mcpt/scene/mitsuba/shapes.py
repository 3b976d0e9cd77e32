"""Mitsuba 3 shapes -> mcpt mesh entries (``file`` or ``shape``, ``transform``, ``flip_normals``).

``obj`` is read by Assimp, ``ply`` by mcpt/shapes/ply.py, ``serialized`` by mcpt/shapes/serialized.py; ``rectangle``,
``cube``, ``disk``, ``sphere`` (``center``, ``radius``) and ``cylinder`` (``p0``, ``p1``, ``radius``)
are tessellated (mcpt/shapes/primitives.py) in Mitsuba's own frame, their parameters folded into
the transform. ``shapegroup`` / ``instance`` are flattened: each member placed by
``instance.to_world · member.to_world``. Smooth shading follows Mitsuba: analytic curved shapes
shade with their true normals, meshes with vertex normals unless ``face_normals`` is true.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...shapes.primitives import KINDS
from . import values as V
from .textures import emitter_texture
from .xmltree import Node, deref, resolve_file

FILE_SHAPES = ("obj", "ply", "serialized")
SUPPORTED = FILE_SHAPES + KINDS + ("shapegroup", "instance")
#: Most shapes one scene may expand to (instances of groups of instances ...): bounds the work.
MAX_SHAPES = 100_000


@dataclass
class ShapeOut:
    """One flattened shape: its mesh entry (no material yet), the BSDF node (or None: Mitsuba's
    default diffuse 0.5), its area emitter's radiance (or None), and whether it shades smoothly."""

    node: Node
    mesh: dict
    bsdf: Node | None
    radiance: tuple[float, float, float] | None
    smooth: bool
    media: dict = field(default_factory=dict)  # issue #25: "interior" / "exterior" -> <medium> node
    radiance_texture: dict | None = None  # issue #22: a bitmap radiance (mcpt's emission_texture)
    placed_by: Node | None = None  # issue #24: the top-level <shape type="instance"> it came through


def _folded(kind: str, props: dict[str, Node], node: Node) -> np.ndarray:
    """The matrix from the primitive's own parameters (centre/radius, p0/p1/radius)."""
    m = np.eye(4)
    if kind == "sphere":
        c = V.as_point(props["center"]) if "center" in props else (0.0, 0.0, 0.0)
        r = V.as_float(props["radius"]) if "radius" in props else 1.0
        if not r > 0:
            raise props["radius"].error(f"radius {r} must be positive")
        m[:3, :3] *= r
        m[:3, 3] = c
    elif kind == "cylinder":
        p0 = np.array(V.as_point(props["p0"]) if "p0" in props else (0.0, 0.0, 0.0))
        p1 = np.array(V.as_point(props["p1"]) if "p1" in props else (0.0, 0.0, 1.0))
        r = V.as_float(props["radius"]) if "radius" in props else 1.0
        axis = p1 - p0
        length = float(np.linalg.norm(axis))
        if not length > 0 or not r > 0:
            raise node.error("a cylinder needs p0 != p1 and a positive radius")
        z = axis / length
        x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        m[:3, :3] = np.stack([x * r, y * r, z * length], 1)
        m[:3, 3] = p0
    return m


def _check_sphere(m: np.ndarray, node: Node) -> None:
    """Mitsuba keeps a sphere round under any to_world (it takes a radius from it); mcpt would
    stretch it, so a non-uniform scale or shear is refused."""
    a = m[:3, :3]
    gram = a.T @ a
    s = float(np.mean(np.diag(gram)))
    if not np.allclose(gram, s * np.eye(3), rtol=1e-6, atol=1e-9 * s):
        raise node.error("to_world has non-uniform scale or shear: Mitsuba would still render a "
                         "sphere, mcpt an ellipsoid; refused")


def _matrix_dict(m: np.ndarray) -> dict:
    return {} if np.array_equal(m, np.eye(4)) else {"transform": {"matrix": m.tolist()}}


def shape(node: Node, ids: dict[str, Node], parent: np.ndarray, out: list[ShapeOut],
          active: tuple[str, ...] = (), placed_by: Node | None = None) -> None:
    """Append the flattened shapes of ``<shape>`` ``node`` (placed by ``parent``; through the
    top-level instance ``placed_by``, if any) to ``out``."""
    kind = node.get("type")
    if kind not in SUPPORTED:
        raise node.error(f"not supported by mcpt (supported: {', '.join(SUPPORTED)})")
    props = V.properties(node)
    local = V.as_transform(props["to_world"]) if "to_world" in props else np.eye(4)
    if kind == "shapegroup":
        return  # only reached through an instance
    if kind == "instance":
        refs = [c for c in node.children if c.tag in ("ref", "shape")]
        if len(refs) != 1:
            raise node.error("an instance needs exactly one <ref id=...> to a shapegroup")
        group = deref(refs[0], ids)
        if group.tag != "shape" or group.get("type") != "shapegroup":
            raise refs[0].error("an instance must refer to a <shape type=\"shapegroup\">")
        ident = group.get("id", "")
        if ident in active:
            raise node.error(f"instance cycle: {' -> '.join(active + (ident,))}")
        for member in group.children:
            if member.tag in ("shape", "ref"):
                shape(deref(member, ids), ids, parent @ local, out, active + (ident,), placed_by or node)
        return
    if len(out) >= MAX_SHAPES:
        raise node.error(f"the scene expands to more than {MAX_SHAPES} shapes")
    matrix = parent @ local
    bsdf = emitter = None
    media = {}
    for child in node.children:
        target = deref(child, ids) if child.tag == "ref" else child
        if target.tag == "bsdf":
            bsdf = target
        elif target.tag == "emitter":
            emitter = target
        elif target.tag == "medium" and child.get("name") in ("interior", "exterior"):  # issue #25
            media[child.get("name")] = target
        elif target.tag in ("medium", "sensor"):
            raise target.error("not supported by mcpt inside a shape (media: name=\"interior\" or "
                               "\"exterior\"; no shape sensors)")
    radiance = radiance_texture = None
    if emitter is not None:
        if emitter.get("type") != "area":
            raise emitter.error("not supported by mcpt on a shape (supported: area)")
        eprops = V.properties(emitter)
        radiance = V.as_color(eprops["radiance"]) if "radiance" in eprops else (1.0, 1.0, 1.0)
        radiance_texture = emitter_texture(emitter, ids)
    flip = V.as_bool(props["flip_normals"]) if "flip_normals" in props else False
    mesh: dict = {}
    if kind in FILE_SHAPES:
        if "filename" not in props:
            raise node.error("missing <string name=\"filename\">")
        path = resolve_file(node, V.as_string(props["filename"]))
        if not path.is_file():
            raise props["filename"].error(f"mesh file not found: {path}")
        mesh["file"] = str(path)
        if kind == "serialized":
            mesh["shape_index"] = V.as_int(props["shape_index"]) if "shape_index" in props else 0
        smooth = not (V.as_bool(props["face_normals"]) if "face_normals" in props else False)
    else:
        matrix = matrix @ _folded(kind, props, node)
        if kind == "sphere":
            _check_sphere(matrix, node)
        mesh["shape"] = kind
        smooth = kind in ("sphere", "cylinder")
    if flip:
        mesh["flip_normals"] = True
    mesh.update(_matrix_dict(matrix))
    out.append(ShapeOut(node, mesh, bsdf, radiance, smooth, media, radiance_texture, placed_by))


def relative_paths(data: dict, folder: Path) -> dict:
    """``data`` with mesh and texture paths relative to ``folder`` where possible (for convert)."""
    import os

    def rel(p: str) -> str:
        try:
            return os.path.relpath(p, folder)
        except ValueError:  # another drive (Windows)
            return p

    for mesh in data.get("meshes", []):
        if "file" in mesh:
            mesh["file"] = rel(mesh["file"])
    for mat in data.get("materials", {}).values():
        for key in ("albedo_texture", "normal_map", "bump_map", "opacity"):
            if "file" in mat.get(key, {}):
                mat[key]["file"] = rel(mat[key]["file"])
    if "file" in (data.get("environment") or {}):  # issue #20: an envmap's image
        data["environment"]["file"] = rel(data["environment"]["file"])
    return data
