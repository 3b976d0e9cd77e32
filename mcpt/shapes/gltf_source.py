"""glTF 2.0 geometry sources (issue #19), plugged into mesh.py's one dispatch point (``READERS``).

Two ways a glTF reaches the geometry:

* :class:`GltfPrimitive` (kind ``"gltf-primitive"``): one primitive of the file, in its mesh's own
  frame; a scene mesh entry ``file: model.glb`` + ``shape_index: N`` (what ``mcpt render
  model.glb`` builds, mcpt/scene/gltf/scene.py) places it with its node's world matrix as the
  entry's ``transform``, so it goes through mesh.assemble like every other source.
* a ``.gltf`` / ``.glb`` path without ``shape_index`` (a YAML scene placing the whole file): every
  node of the default scene that carries a mesh, its primitives moved by the node's world matrix
  here, with the file's materials as MTL-like :class:`MeshMaterial` (base colour -> kd, its
  texture -> kd_map, emission -> ke): the diffuse approximation that a mesh file's own materials
  get (mcpt/scene/material_meaning.py). A material that maps to more than that (a metal) is warned.

The file is parsed once (mcpt/scene/gltf/container.py keeps it) and read with numpy: Assimp is
not used, so cameras, materials and geometry come from one reading of the same JSON.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..scene.gltf import GltfError, open_gltf
from ..scene.gltf import geometry as gltf_geometry
from ..scene.gltf import materials as gltf_materials
from ..scene.gltf import nodes as gltf_nodes
from ..scene.gltf.scene import MAX_TRIANGLES
from .mesh import READERS
from .raw_mesh import FileShape, MeshError, MeshMaterial, RawMesh, RawPart, TextureMap

log = logging.getLogger("mcpt")


@dataclass(frozen=True)
class GltfPrimitive(FileShape):
    """Primitive ``index`` (file order across meshes) of the glTF file ``path``."""

    kind: str = "gltf-primitive"
    what: ClassVar[str] = "primitive"


def _part(prim, material: int = 0, matrix: np.ndarray | None = None) -> RawPart:
    positions, normals, indices = prim.positions, prim.normals, prim.indices
    if matrix is not None:
        linear = matrix[:3, :3]
        positions = positions @ linear.T + matrix[:3, 3]
        if normals is not None:
            normals = normals @ np.linalg.inv(linear)  # covectors: inverse transpose
        if np.linalg.det(linear) < 0:  # a mirror: keep counter-clockwise = front
            indices = indices.reshape(-1, 3)[:, ::-1].copy()
    return RawPart(prim.label, positions, indices, material, normals, prim.uvs)


def read_primitive(source: GltfPrimitive, *, need_normals: bool = False) -> RawMesh:
    try:
        prim = gltf_geometry.read(open_gltf(source.path), source.index)
    except GltfError as exc:
        raise MeshError(str(exc)) from None
    return RawMesh(source.path, [_part(prim)])


def _mesh_material(g, index) -> MeshMaterial:
    """A glTF material as a mesh file's own (diffuse) material."""
    m = gltf_materials.material(g, index)
    name = gltf_materials.material_name(g, index)
    if m["type"] != "diffuse":
        log.warning("%s: material %r (%s) is placed from a YAML scene as a diffuse of its base colour; "
                    "render the glTF file itself for its own materials", g.path, name, m["type"])
    tex = m.get("albedo_texture")
    kd_map = TextureMap(g.path, "baseColorTexture", Path(tex["file"])) if tex else None
    ke = tuple(m["emission"]) if "emission" in m else None
    return MeshMaterial(name, tuple(m["albedo"]) if "albedo" in m else None, ke, kd_map)


def read_file(path: Path, *, need_normals: bool = False) -> RawMesh:
    """Every mesh of the file's default scene, placed by its node, with the file's materials."""
    try:
        g = open_gltf(path)
        prims = gltf_geometry.primitives(g)
        placed, slots, triangles = [], {}, 0
        for ni, world in gltf_nodes.instances(g):
            node = g.get("nodes", ni)
            if "mesh" not in node or np.linalg.det(world[:3, :3]) == 0.0:  # zero scale hides a node
                continue
            g.get("meshes", node["mesh"], f"nodes[{ni}]")
            for number in gltf_geometry.of_mesh(g, node["mesh"]):
                mi, pi, prim = prims[number]
                triangles += gltf_geometry.check(g, mi, pi, prim)  # sizes first: bounded memory
                if triangles > MAX_TRIANGLES:
                    raise g.error(f"nodes[{ni}]", f"the placed meshes add up to more than {MAX_TRIANGLES} triangles")
                placed.append((number, world, slots.setdefault(prim.get("material"), len(slots))))
        parts = [_part(gltf_geometry.read(g, number), slot, world) for number, world, slot in placed]
        materials = [_mesh_material(g, mat) for mat in slots]
    except GltfError as exc:
        raise MeshError(str(exc)) from None
    if not parts:
        raise MeshError(f"{path}: no node of the scene places a mesh")
    return RawMesh(path, parts, materials)


READERS["gltf-primitive"] = read_primitive
READERS[".gltf"] = read_file
READERS[".glb"] = read_file
