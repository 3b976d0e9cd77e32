"""The scene: a YAML file described as validated, immutable Python objects (the first room).

``load_scene(path)`` reads and validates a file; every mistake is one :class:`SceneError` line
naming file, line and key. Nothing here loads meshes or touches GL: mcpt/shapes/world.py turns a
Scene into render-ready data. Modules: ``reader`` (YAML with line numbers), ``model`` (camera,
render settings, meshes, the scene root), ``materials``, ``transform``, ``fields`` (shared field
types), ``diagnostics`` (error wording), ``material_meaning`` (what the scene's and the mesh
files' materials mean as rows of the material table; used by the world's build).
"""

from .diagnostics import SceneError
from .fields import MAX_RESOLUTION, TEXTURE_SUFFIXES
from .materials import MATERIAL_KEYS, Absorption, Material
from .model import Camera, Mesh, RenderSettings, Scene
from .reader import load_scene, parse_scene
from .textures import ImageTexture
from .transform import Transform

__all__ = ["MAX_RESOLUTION", "MATERIAL_KEYS", "TEXTURE_SUFFIXES", "Absorption", "Camera", "ImageTexture",
           "Material", "Mesh", "RenderSettings", "Scene", "SceneError", "Transform", "load_scene",
           "parse_scene"]
