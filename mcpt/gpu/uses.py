"""What a scene uses (mcpt/gpu/features.py's first group): which shader code and which buffers a
render needs, read off the world by features.for_world, and the material table's layout that
follows from it (texels per material, where texel 4 and the specular weights sit; host side:
mcpt/shading/materials.py MaterialTable.pack)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass(frozen=True)
class Uses:
    """What the scene uses: which code and which buffers it needs (from the world alone)."""

    lights: bool = True             # any light (NEE needs one)
    single_light: bool = False      # exactly one light: no light CDF search
    light_steps: int = 0            # 2..16 lights: the CDF search's steps, written out (0: the loop)
    # issue #20: the light types present (mcpt/shading/lights.py light_uses), each compiled alone
    area_lights: bool = True        # emissive triangles
    point_lights: bool = False
    spot_lights: bool = False
    directional_lights: bool = False
    sun_lights: bool = False        # a directional light with a disk (not delta: escaping rays see it)
    environment: bool = False       # an environment (constant, or a map:)
    envmap: bool = False            # an environment map (glsl/envmap.glsl, TBO units 10-11)
    bvh: bool = True                # False: brute-force loop over all triangles
    bvh_dense: bool = False         # wide-leaf traversal for heavily overlapping trees (bvh.py BVH.dense)
    diffuse: bool = True            # Lambertian material present
    conductor: bool = False         # conductor (mirror or rough metal) present
    microfacet: bool = False        # some conductor is rough: GGX code
    beckmann: bool = False          # some rough material is Beckmann (mcpt/shading/microfacet.py)
    separable_masking: bool = False  # some rough material has masking: separable
    rough_dielectric: bool = False  # rough glass present (mcpt/shading/roughdielectric.py)
    thin_dielectric: bool = False   # thin glass present (mcpt/shading/thindielectric.py)
    rough_plastic: bool = False     # rough plastic present: its 16-texel table (roughplastic.py)
    metalrough: bool = False        # glTF metal-rough present (mcpt/shading/metalrough.py)
    metalrough_specular: bool = False  # some metal-rough has KHR_materials_ior / _specular: texel 4
    dielectric: bool = False        # smooth glass present
    absorption: bool = False        # some dielectric absorbs (Beer-Lambert)
    plastic: bool = False           # diffuse base under a smooth dielectric coat present
    textures: bool = False          # some albedo is an image: UV buffer, texel buffer
    emission_textures: bool = False  # issue #22: some emission is an image (emission_texture.py)
    float_textures: bool = False    # issue #22: some texture is EXR / HDR / 16-bit (float_texture.py)
    specular_weights: bool = False  # issue #22: some glass / plastic has a specular factor != 1 (2 texels)
    roughness_textures: bool = False  # issue #22: some alpha is read per hit (roughness_texture.py)
    smooth_normals: bool = False    # some material shades with vertex normals: normal buffer
    fresnel_complex: bool = False   # some conductor has fresnel: conductor (eta, k): 5th texel
    one_sided: bool = False         # some material has two_sided: false (black back side)
    normal_maps: bool = False       # some material has a normal map: tangent and map buffers
    opacity: bool = False           # some material has an opacity texture: any-hit test in traversal
    pixel_filter: int = 0           # 0 box, 1 tent, 2 Gaussian: filter importance sampling (pixel_filter.py)
    thin_lens: bool = False         # depth of field: a point on the lens per sample (2 more dims)
    orthographic: bool = False      # parallel camera rays
    medium: bool = False            # issue #25: some participating medium (mcpt/shading/medium.py)
    interior_media: bool = False    # issue #25: some dielectric bounds an interior medium
    tri_const: int = 0              # > 0: no BVH, the brute-force loop written out for this many
    tri_first: int = 0              # with tri_const: the first of them (BVH: the large tail)
    bvh_start: int = 0              # with BVH and tri_const: where traversal starts (bvh.py large_tail)
    vert_addr: tuple = ()           # with tri_const: u_tris texel of each distinct vertex
    tri_vert_ids: tuple = ()        # with tri_const: each corner's distinct-vertex index
    vert_pos: tuple = ()            # with tri_const: each distinct vertex's x, y, z float32 bits
    spheres: int = 0                # analytic spheres, each tested by every ray (mcpt/shapes/sphere.py)
    camera_moves: bool = False      # issue #26: an animated camera, its eye a uniform (camera.glsl)

    def everything(self) -> Uses:
        """Every optional code path (the uber-shader); the geometry's layout stays as it is."""
        return dataclasses.replace(
            self, lights=True, single_light=False, light_steps=0, area_lights=True, point_lights=True, spot_lights=True,
            directional_lights=True, sun_lights=True, environment=True, bvh=True, diffuse=True, conductor=True,
            microfacet=True, dielectric=True, absorption=True, plastic=True, textures=True, smooth_normals=True,
            fresnel_complex=True, one_sided=True, normal_maps=True, opacity=True, beckmann=True,
            separable_masking=True, rough_dielectric=True, thin_dielectric=True, rough_plastic=True, metalrough=True,
            metalrough_specular=True, medium=True, interior_media=True, emission_textures=True,
            float_textures=True, specular_weights=True, roughness_textures=True)

    @property
    def delta(self) -> bool:
        """Some material has a specular (delta) lobe: light found through it is not MIS-weighted."""
        return self.conductor or self.dielectric or self.plastic or self.rough_dielectric or self.thin_dielectric

    @property
    def transmission(self) -> bool:
        """Some material refracts: offsets to the other side, eta-corrected roulette."""
        return self.dielectric or self.rough_dielectric or self.thin_dielectric

    @property
    def material_texels(self) -> int:
        """Texels per material in the table: 2 for diffuse-only scenes, 4 with any parameter, 5
        with a complex-Fresnel conductor (its k)."""
        table = (16 if self.rough_plastic else 0) + (2 if self.specular_weights else 0)
        if self.fifth_texel:
            return 5 + table
        extra = (self.conductor or self.dielectric or self.plastic or self.textures or self.smooth_normals
                 or self.one_sided or self.rough_dielectric or self.thin_dielectric or self.rough_plastic
                 or self.metalrough)
        return (4 if extra else 2) + table

    @property
    def fifth_texel(self) -> bool:
        """Texel 4 in use: a complex-Fresnel conductor's k, or a metal-rough row's F0, F90
        (KHR_materials_ior / _specular, issue #21)."""
        return (self.conductor and self.fresnel_complex) or (self.metalrough and self.metalrough_specular)

    @property
    def spec_texel(self) -> int:
        """The first of the 2 specular-weight texels (issue #22), after texel 4 if any; 0: none."""
        if not self.specular_weights:
            return 0
        return 5 if self.fifth_texel else 4

    @property
    def written_out(self) -> int:
        """Triangles glsl/bvh.glsl tests in a written-out loop: a small scene's all (no BVH), or
        the large tail of a (non-dense) BVH's triangles, before traversing the rest."""
        if self.bvh and (self.bvh_dense or not self.bvh_start):
            return 0
        return self.tri_const
