"""A glTF 2.0 file -> the plain data of an mcpt YAML scene (then validated as one).

:func:`scene_data` walks the default scene's node hierarchy (nodes.py): the chosen camera
(camera.py) becomes mcpt's camera; every node that carries a mesh places each of its primitives
as one scene mesh entry: ``file`` the glTF, ``shape_index`` the primitive's number (geometry.py;
read by mcpt/shapes/gltf_source.py), ``transform`` the node's world matrix, ``material`` the
primitive's glTF material mapped by materials.py (one scene material per glTF material used);
every node that carries a ``KHR_lights_punctual`` light places it (lights.py, issue #20).
Every accessor, view and buffer used is checked from the declared sizes first, and the buffers
are read once (the parsed file is shared with the geometry reader), so a short or lying buffer is
refused at load time in one line. The data is then validated by the same
:class:`~mcpt.scene.Scene` model as a YAML file (:func:`load_gltf`): the loader stays the only
road from data to objects.

What a glTF cannot say comes from the command line (--spp, --bounces, --resolution; defaults:
RenderSettings's and camera.DEFAULT_HEIGHT); ``-D camera=NAME`` picks a camera by its name or
its node's name; dotted ``-D`` keys override the converted scene's keys as for YAML.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..mapped import validated
from ..model import Scene
from . import camera as cameras
from . import geometry, nodes
from .animation import animation_data
from .container import Gltf, GltfError, open_gltf
from .lights import lights
from .materials import material, material_name

log = logging.getLogger("mcpt")

#: Options a glTF file takes as ``-D NAME=VALUE`` (undotted).
OPTIONS = ("camera",)
#: Most triangles the placed meshes may add up to (instances counted), checked before reading.
MAX_TRIANGLES = 2**26
#: Extensions mcpt reads or may ignore (the rest, when required by the file, are refused).
SUPPORTED_EXTENSIONS = ("KHR_materials_emissive_strength", "KHR_texture_transform", "KHR_lights_punctual",
                        "KHR_materials_ior", "KHR_materials_specular")  # issue #21 item 5


def split_options(overrides, path) -> tuple[dict[str, str], list[str]]:
    """``-D`` texts as glTF options (``camera=NAME``) and dotted scene-key overrides."""
    options, keys = {}, []
    for text in overrides:
        name, sep, value = text.partition("=")
        name = name.strip()
        if "." in name:
            keys.append(text)
        elif not sep or name not in OPTIONS:
            raise GltfError(path, None, "", f"-D {text}: a glTF file takes {', '.join(OPTIONS)}=VALUE "
                                            "or a dotted scene key (camera.resolution=[W,H])")
        else:
            options[name] = value
    return options, keys


def _check_extensions(g: Gltf) -> None:
    required = g.doc.get("extensionsRequired", [])
    for ext in required if isinstance(required, list) else []:
        if ext not in SUPPORTED_EXTENSIONS:
            raise g.error("extensionsRequired", f"{ext} is not supported by mcpt")


def _meshes(g: Gltf, placed, prims, owners: list | None = None) -> tuple[list[dict], dict[str, dict]]:
    """The scene's mesh entries and materials for the placed nodes (``owners``: filled with each
    entry's node, for the animation, issue #26)."""
    meshes: list[dict] = []
    materials: dict[str, dict] = {}
    names: dict = {}          # (glTF material index or None, has normals) -> scene material name
    triangles = 0
    for ni, world in placed:
        node = g.get("nodes", ni)
        if "mesh" not in node:
            continue
        g.get("meshes", node["mesh"], f"nodes[{ni}]")
        linear = world[:3, :3]
        if abs(np.linalg.det(linear)) <= 1e-12 * max(float(np.abs(linear).max()), 1e-300) ** 3:
            log.info("%s: nodes[%d]: zero scale, not rendered", g.path, ni)
            continue
        for number in geometry.of_mesh(g, node["mesh"]):
            mi, pi, prim = prims[number]
            triangles += geometry.check(g, mi, pi, prim)
            if triangles > MAX_TRIANGLES:
                raise g.error(f"nodes[{ni}]", f"the placed meshes add up to more than {MAX_TRIANGLES} triangles")
            # glTF shades with the vertex normals it gives, flat without (spec 3.7.2.1).
            key = (prim.get("material"), "NORMAL" in prim["attributes"])
            if key not in names:
                names[key] = _unique(material_name(g, key[0]), materials)
                materials[names[key]] = material(g, key[0]) | ({"smooth_normals": True} if key[1] else {})
            meshes.append({"file": str(g.path), "shape_index": number, "material": names[key],
                           "transform": {"matrix": world.tolist()}})
            if owners is not None:
                owners.append(ni)
    return meshes, materials


def _unique(name: str, taken: dict) -> str:
    out, n = name, 2
    while out in taken:
        out, n = f"{name}_{n}", n + 1
    return out


def scene_data(path: str | Path, options: dict[str, str] | None = None) -> dict:
    """The YAML-schema data of the glTF file at ``path`` (``options``: see :data:`OPTIONS`)."""
    g = open_gltf(path)
    options = options or {}
    _check_extensions(g)
    placed = nodes.instances(g)
    node, world = cameras.choose(g, placed, options.get("camera"))
    cam = cameras.camera(g, node, world)
    owners: list = []
    meshes, materials = _meshes(g, placed, geometry.primitives(g), owners)
    if not meshes:
        raise g.error("nodes", "no node of the scene places a mesh: nothing to render")
    for i in range(len(g.items("buffers"))):
        g.buffer(i)  # read (and check) every buffer now: shared with the geometry reader
    data = {"name": Path(path).stem, "camera": cam, "render": {}, "materials": materials, "meshes": meshes}
    if found := lights(g, placed):  # issue #20: KHR_lights_punctual (gltf/lights.py)
        data["lights"] = found
    if anim := animation_data(g, placed, owners):  # issue #26: node TRS channels (gltf/animation.py)
        data["animation"] = anim
    return data


def load_gltf(path: str | Path, overrides=()) -> Scene:
    """Read, map and validate a glTF 2.0 scene (``.gltf`` or ``.glb``; ``overrides``: ``-D``
    texts, see :func:`split_options`). Raises :class:`~mcpt.scene.SceneError` (one line)."""
    path = Path(path)
    options, keys = split_options(overrides, path)
    data = scene_data(path, options)
    return validated(data, {}, path, keys)
