"""glTF 2.0 scenes (issue #19): ``.gltf`` / ``.glb`` read, mapped onto mcpt's scene schema,
validated like YAML.

Modules, in data order: ``container`` (JSON, GLB chunks, buffers), ``accessors`` (typed views of
the buffers), ``nodes`` (the hierarchy's world matrices), ``camera``, ``images`` (texture files),
``materials`` (metal-rough -> mcpt), ``geometry`` (primitives' vertex arrays), ``scene`` (the walk,
and :func:`load_gltf`). The geometry source that renders a primitive is
mcpt/shapes/gltf_source.py. What is supported, approximated (with the warning) or refused:
README "glTF 2.0 scenes".
"""

from .container import GltfError, open_gltf
from .scene import load_gltf, scene_data, split_options

__all__ = ["GltfError", "load_gltf", "open_gltf", "scene_data", "split_options"]
