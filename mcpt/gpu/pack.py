"""Packing: a built world -> the buffer-texture arrays and uniforms one program needs (the data diet).

Only what the features ask for is packed: the BVH when the scene is large enough to use it, the
light table when there is light sampling, corner normals and UVs/texels only when some material
reads them. Each array's layout is documented by its host module, named after the GLSL file that
reads it:

    tris       mcpt/shapes/geometry.py   <-> glsl/geometry.glsl
    spheres    mcpt/shapes/sphere.py     <-> glsl/sphere.glsl (analytic spheres)
    nodes      mcpt/shapes/bvh.py        <-> glsl/bvh.glsl
    lights     mcpt/shading/lights.py    <-> glsl/lights.glsl (+ light_punctual)
    env_texels, env_alias  mcpt/shading/envmap.py <-> glsl/envmap.glsl (environment maps)
    materials  mcpt/shading/materials.py <-> glsl/materials.glsl
    normals    mcpt/shading/normals.py   <-> glsl/normals.glsl
    uvs, textures  mcpt/shading/texture.py <-> glsl/texture.glsl
    emit_pdf   mcpt/shading/emission_texture.py <-> glsl/emission_texture.glsl
    camera     mcpt/shading/camera.py    <-> glsl/camera.glsl (uniforms)
    medium     mcpt/shading/medium.py    <-> glsl/medium.glsl (uniforms; issue #25)

The integrator's other pieces have host twins that pack no array (a define or a layout only):

    random dims        mcpt/shading/sampler.py   <-> glsl/sampler.glsl (MCPT_DIM_* defines)
    roulette           mcpt/shading/roulette.py  <-> glsl/roulette.glsl (MCPT_RR_START)
    path state images  mcpt/gpu/path_state.py    <-> glsl/path_state.glsl (continuation)
    AOV targets        mcpt/gpu/aov.py           <-> glsl/aov.glsl
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene.animation import eye_offset
from ..shading.camera import camera_uniforms
from ..shading.emission_texture import pack_emit_pdf
from ..shading.environment import env_uniforms
from ..shading.light_sun import sun_uniforms
from ..shading.lights import material_light_pdf_area
from ..shading.medium import medium_uniforms
from ..shading.normal_map import pack_normal_maps, pack_tangents
from ..shading.normals import pack_normals
from ..shading.texture import pack_textures, pack_uvs
from ..shapes.geometry import pack_triangles
from ..shapes.sphere import TEXELS as SPHERE_TEXELS
from ..shapes.world import World
from .features import Features

# Texels per item of each buffer, so a size error can say how many items would fit.
ITEMS = {"tris": (3, "triangles"), "nodes": (4, "BVH nodes"), "materials": (2, "materials"),
         "lights": (1, "lights"), "normals": (1, "triangles"), "uvs": (2, "triangles"),
         "tangents": (1, "triangles"), "spheres": (SPHERE_TEXELS, "spheres")}


@dataclass(frozen=True)
class Packed:
    """Everything the GPU side needs of a world, and nothing of the world itself."""

    width: int                                   # image size, pixels
    height: int
    buffers: dict[str, np.ndarray]               # by TBO name (mcpt/gpu/tbo.py UNITS)
    uniforms: dict = field(default_factory=dict)  # by GLSL uniform name
    per_item: dict = field(default_factory=dict)  # TBO name -> (texels per item, item name)


def pack(world: World, features: Features) -> Packed:
    cam = world.scene.camera
    buffers = {"tris": pack_triangles(world.tris, world.tri_material),
               "materials": world.materials.pack(
                   material_light_pdf_area(world.materials.emission, world.lights.total_power),
                   texels=features.material_texels, emission_textures=features.compiled.emission_textures,
                   spec_texel=features.compiled.spec_texel, fifth=features.compiled.fifth_texel)}
    if world.n_spheres:
        buffers["spheres"] = world.spheres
    if features.bvh:
        buffers["nodes"] = world.bvh.gpu_nodes(world.tris, dense=features.bvh_dense)
    if features.nee:
        buffers["lights"] = world.lights.pack()
        if features.compiled.emission_textures:  # issue #22: the per-triangle area density
            buffers["emit_pdf"] = pack_emit_pdf(world.lights, world.n_triangles)
    # The uber-shader (--features all) declares these buffers for any scene, but reads them only
    # for materials that have smooth normals / a texture: without such a material nothing is
    # read, so nothing is uploaded.
    if features.smooth_normals and world.normals is not None:
        buffers["normals"] = pack_normals(world.normals)
    if features.textures and world.textures:
        buffers["uvs"] = pack_uvs(world.uvs)
        buffers["textures"] = pack_textures(world.textures)
    if features.normal_maps or features.opacity:  # the map table always (every material is looked up)
        buffers["normal_maps"] = pack_normal_maps(world.materials.normal_map, world.materials.opacity)
        if features.normal_maps and world.tangents is not None:
            buffers["tangents"] = pack_tangents(world.tangents)
    uniforms = {**camera_uniforms(cam), "u_tri_count": world.n_triangles,
                "u_light_count": world.lights.entries}
    if features.compiled.camera_moves:  # issue #26: the eye relative to the rebased geometry
        uniforms["u_cam_eye"] = eye_offset(world.scene)
    if features.compiled.sun_lights:
        uniforms.update(sun_uniforms(world.lights, world.scene.where("lights")))
    if features.compiled.environment:
        uniforms.update(env_uniforms(world.scene.environment, world.lights.envmap,
                                     world.lights.env_pmf if features.nee else 0.0))
    if features.compiled.medium:
        uniforms.update(medium_uniforms(world, features.compiled.interior_media))
    if features.compiled.envmap and world.lights.envmap is not None:
        buffers.update(world.lights.envmap.pack())
    per_item = dict(ITEMS, materials=(features.material_texels, "materials"))
    return Packed(cam.width, cam.height, buffers, uniforms, per_item)
