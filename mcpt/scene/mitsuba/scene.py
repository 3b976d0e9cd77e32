"""A Mitsuba 3 scene file -> the plain data of an mcpt YAML scene (then validated as one).

:func:`scene_data` walks the expanded tree (xmltree.py) and maps sensor, integrator, shapes,
BSDFs and emitters (camera.py, shapes.py, bsdfs.py) onto the YAML schema of mcpt/scene/model.py.
Materials are keyed by what they are: one entry per distinct (BSDF, two-sidedness, emitted
radiance, smooth shading), named after the BSDF's ``id`` where it has one. The data is then
validated by the same :class:`~mcpt.scene.Scene` model as a YAML file (:func:`load_xml`): the
loader stays the only road from data to objects.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from ..mapped import validated
from ..model import Scene
from . import bsdfs, camera
from .emitters import emitter
from .media import add_medium, check_null_lights, scene_medium, shape_material
from .shapes import ShapeOut, shape
from .xmltree import Node, XmlError, deref, read_tree

log = logging.getLogger("mcpt")

#: Top-level objects mcpt maps, and those it reads only through references.
TOP_LEVEL = ("sensor", "integrator", "shape", "bsdf", "texture", "emitter", "medium", "phase")
#: Objects Mitsuba lets a scene declare at the top level with an ``id`` and place elsewhere by
#: ``<ref id>``: an area emitter a shape refers to (Mitsuba's cbox-rgb.xml, variants_cbox_rgb.xml),
#: a sampler or film a sensor refers to (its documentation's sampler_*.xml). Such a
#: declaration is not an object of the scene itself; where it is placed, it is read (and refused
#: if unsupported) as if written there.
DECLARABLE = ("emitter", "sampler", "film")
#: Mitsuba's material when a shape names none: a one-sided diffuse of reflectance 0.5 (0 when the
#: shape emits: Mitsuba's Shape constructor).
DEFAULT_MATERIAL = {"type": "diffuse", "albedo": [0.5, 0.5, 0.5], "two_sided": False}


def split_defines(overrides, path) -> tuple[dict[str, str], list[str]]:
    """``-D`` texts as Mitsuba parameters (``name=value``) and mcpt scene-key overrides (a dotted
    key such as ``camera.resolution=[64,64]``, applied to the converted data)."""
    params, keys = {}, []
    for text in overrides:
        name, sep, value = text.partition("=")
        if not sep or not name.strip():
            raise XmlError(path, None, "", f"-D {text}: expected NAME=VALUE")
        if "." in name:
            keys.append(text)
        else:
            params[name.strip()] = value
    return params, keys


def _referenced_ids(root: Node) -> set[str]:
    """Every id a ``<ref id>`` anywhere in the tree names."""
    out: set[str] = set()
    stack = [root]
    while stack:
        node = stack.pop()
        if node.tag == "ref" and "id" in node.attrs:
            out.add(node.attrs["id"])
        stack.extend(node.children)
    return out


def scene_data(path: str | Path, defines: dict[str, str] | None = None) -> tuple[dict, dict]:
    """(YAML-schema data, key path -> XML line) of the Mitsuba scene at ``path``."""
    tree = read_tree(path, defines)
    lines: dict[tuple[str, ...], int] = {(): tree.root.line}
    sensor = None
    integrator = None
    shapes: list[ShapeOut] = []
    lights: list[dict] = []
    environment = None
    referenced = _referenced_ids(tree.root)
    for node in tree.root.children:
        if node.tag in DECLARABLE and node.get("id") in referenced:
            continue  # a declaration: it takes effect where a <ref> places it (a shape, a sensor)
        if node.tag not in TOP_LEVEL:
            if node.tag in ("ref",):
                continue
            raise node.error(f"not supported by mcpt at the top level (supported: {', '.join(TOP_LEVEL)})")
        if node.tag == "sensor":
            if sensor is not None:
                log.warning("%s:%d: %s: a second sensor; mcpt renders the first (line %d)",
                            node.file, node.line, node.label, sensor.line)
            else:
                sensor = node
        elif node.tag == "integrator":
            integrator = node
        elif node.tag == "shape":
            shape(node, tree.ids, np.eye(4), shapes)
        elif node.tag == "emitter":
            where, light = emitter(node)  # issue #20: punctual lights, constant environment
            if where == "environment":
                if environment is not None:
                    raise node.error("a second environment emitter (mcpt takes one)")
                environment = light
                lines[("environment",)] = node.line
            else:
                lines[("lights", str(len(lights)))] = node.line
                lights.append(light)
    if sensor is None:
        raise XmlError(path, tree.root.line, "<scene>", "no <sensor>: mcpt needs a perspective camera")
    objects = [deref(c, tree.ids) for c in sensor.children if c.tag in ("film", "sampler", "ref")]
    cam, render = camera.sensor(sensor, objects)
    render["bounces"] = camera.integrator(integrator)
    fog = scene_medium(sensor, shapes, integrator, tree.ids)  # issue #25: the camera's medium
    check_null_lights(shapes, lights, lines)  # issue #25: delta emitters and null boundaries
    lines[("camera",)] = sensor.line
    lines[("render",)] = (integrator or sensor).line
    materials: dict[str, dict] = {}
    by_value: dict[str, str] = {}
    meshes = []
    for i, s in enumerate(shapes):
        mat = shape_material(s, fog, tree.ids, lambda s=s: (  # issue #25: media on shapes
            dict(bsdfs.material(s.bsdf, tree.ids)) if s.bsdf is not None else dict(DEFAULT_MATERIAL)))
        if s.bsdf is None and s.radiance is not None:
            mat["albedo"] = [0.0, 0.0, 0.0]  # Mitsuba: an emitter without a BSDF reflects nothing
        mat.update(_emission(s))
        if s.smooth:
            mat["smooth_normals"] = True
        key = json.dumps(mat, sort_keys=True)
        if key not in by_value:
            base = (s.bsdf.get("id") if s.bsdf is not None else None) or (
                f"{s.bsdf.get('type')}_{s.bsdf.line}" if s.bsdf is not None else "default")
            name = base
            n = 2
            while name in materials:
                name, n = f"{base}_{n}", n + 1
            by_value[key] = name
            materials[name] = mat
            lines[("materials", name)] = (s.bsdf or s.node).line
        meshes.append({**s.mesh, "material": by_value[key]})
        _mesh_lines(lines, i, s)
    if not meshes:
        raise XmlError(path, tree.root.line, "<scene>", "no shapes: nothing to render")
    name = Path(path).stem
    data = {"name": name, "camera": cam, "render": render, "materials": materials, "meshes": meshes}
    if lights:
        data["lights"] = lights
    if environment is not None:
        data["environment"] = environment
    add_medium(data, lines, fog, tree.ids)
    return data, lines


def _mesh_lines(lines: dict, i: int, s: ShapeOut) -> None:
    """The lines of mesh entry ``i``: its shape's, and the top-level instance's it came through
    (issue #24: a scene too large names the instance where it crosses the limit)."""
    lines[("meshes", str(i))] = s.node.line
    if s.placed_by is not None:
        lines[("meshes", str(i), "instance")] = s.placed_by.line


def _emission(s) -> dict:
    """A shape's area emitter as material keys: ``emission``, or a bitmap radiance as
    ``emission_texture`` of scale 1 (issue #22)."""
    if s.radiance_texture is not None:
        return {"emission": [1.0, 1.0, 1.0], "emission_texture": s.radiance_texture}
    return {"emission": list(s.radiance)} if s.radiance is not None and any(s.radiance) else {}


def load_xml(path: str | Path, overrides=()) -> Scene:
    """Read, map and validate a Mitsuba 3 scene (``overrides``: ``-D`` texts, see
    :func:`split_defines`). Raises :class:`~mcpt.scene.SceneError` (one line)."""
    path = Path(path)
    params, keys = split_defines(overrides, path)
    data, lines = scene_data(path, params)
    return validated(data, lines, path, keys)
