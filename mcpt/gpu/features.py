"""What a program compiles, derived once: the single source of every shader define and of the data diet.

``Features`` is immutable and hashable; :meth:`Features.defines` emits EVERY define as 0/1 (or a
number), so ``#if MCPT_X`` never silently reads an undefined macro, and the program cache is keyed by
:attr:`Features.key`. Its four groups each answer one question: :class:`Uses` (mcpt/gpu/uses.py), what
the scene uses (:func:`for_world` reads it off the world); :class:`Options`, what the render is asked for (depth,
sampler, outputs, clamp); :class:`Limits`, what the driver limits (llvmpipe's loop budget);
:class:`Switches`, what a comparison or a debugging session changes (the estimator, Russian
roulette, counters, path continuation, the uber-shader of ``--features all``), whose defaults are
what a user renders with. Fields are named alike in :func:`derive`, :func:`for_world`,
:meth:`Features.of` and :meth:`Features.replace` (each name is in one group); the host reads the
program as compiled through ``Features``' properties (``features.bvh``, ``features.nee``, ...).

Materials: each type compiles its own ``glsl/bsdf_<type>.glsl`` only when the scene uses it; the
GGX microfacet code only when some conductor is rough (Beckmann and the separable masking term
only when some rough material chooses them: mcpt/shading/microfacet.py); texture and vertex-normal lookups (and
their UV / normal buffers) only when some material has an ``albedo_texture`` / ``smooth_normals``;
the complex (exact conductor) Fresnel and its extra material texel only when some conductor uses
``fresnel: conductor``; the back-side test only when some material is one-sided.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass, fields

import numpy as np

from ..scene.animation import camera_moves
from ..shading import emission_texture, metalrough, microfacet, roughness_texture, specular_weights, thindielectric
from ..shading.camera import camera_uses
from ..shading.lights import count_uses, light_uses
from ..shading.medium import equiangular_used, medium_dims, medium_uses
from ..shading.roulette import RR_START
from ..shading.sampler import dims_for, joint_used, layout_defines
from ..shapes.geometry import shared_vertices, vertex_bits
from .limits import (  # noqa: F401 (re-exported: the names callers know features by)
    LLVMPIPE_LOOP_LIMIT,
    MAX_SAMPLES_PER_DRAW,
    MIN_SAMPLES_PER_DRAW,
    TRI_CONST_MAX,
    loop_limit_for,
    max_loop_iterations,
    needs_continuation,
    vertex_tables,
)
from .options import SAMPLERS, SAMPLING_MODES, Limits, Options, Switches  # noqa: F401 (re-exported)
from .uses import Uses

# Below this many triangles a linear loop beats BVH traversal (measured: bench/, issue #4).
BVH_MIN_TRIANGLES = 64

# Samples per pixel one draw takes with the sobol sampler (path regeneration, glsl/pathtrace.frag):
# lanes whose path ended start the next one instead of idling, and an 8-lane group waits only once
# per draw for its slowest lane, so the more samples a draw holds the less its lanes idle. Measured
# alternating (LP 2 threads, 64 spp, seconds relative to 4 a draw): Cornell box 128x128 16 -> 0.88,
# 32 -> 0.85; 256x256 64 -> 0.82; 512x512 16 -> 0.88, 64 -> 0.83; 100k sphere 128x128 64 -> 0.89
# (the gain is per pixel, not a per-draw overhead: it holds at every size). A draw holds at most
# PATHS_PER_DRAW paths unless that would mean fewer than MIN_SAMPLES_PER_DRAW samples;
# MAX_SAMPLES_PER_DRAW is the read-back chunk (render.py), which a draw never spans.
# needs_continuation below assumes no draw takes more than the maximum. --time and signals step in
# between the bands of a draw (mcpt/gpu/bands.py, issue #24 item 8), not only between draws: fewer
# samples a draw would change every pixel and cost paths/s (Cornell box 256^2 re-measured under
# load, CPU seconds: 32 a draw x0.92-0.96, 16 x0.90). Since the bands, the cap is 2^25 paths
# (was 2^22, ~3 s at the 100k sphere's 1.3 M paths/s), so that 800x600 takes 64 samples a draw
# (was 8): issue #23's headline job, CPU seconds of 64 spp at 800x600 alternating, 8 a draw
# 52.8 s, 32 51.3 s, 64 47.4 s (x0.90). The price: --time stops before a draw it foresees ending
# past the budget, so a large image may end up to one draw (~15 s on llvmpipe) early.
PATHS_PER_DRAW = 1 << 25


def samples_per_draw(width: int, height: int) -> int:
    """Samples per pixel per draw for a ``width`` x ``height`` image (sobol; a power of two)."""
    n = MAX_SAMPLES_PER_DRAW
    while n > MIN_SAMPLES_PER_DRAW and width * height * n > PATHS_PER_DRAW:
        n //= 2
    return n


_GROUPS = {"uses": Uses, "options": Options, "limits": Limits, "switches": Switches}
_GROUP_OF = {f.name: g for g, cls in _GROUPS.items() for f in fields(cls)}  # field -> its group


def _split(flat: dict) -> dict[str, dict]:
    """Flat field names -> one dict per group; an unknown name is an error (a typo is no default)."""
    if unknown := sorted(set(flat) - set(_GROUP_OF)):
        raise TypeError(f"no feature named {unknown} (known: {sorted(_GROUP_OF)})")
    return {g: {k: v for k, v in flat.items() if _GROUP_OF[k] == g} for g in _GROUPS}


@dataclass(frozen=True)
class Features:
    """Everything one program compiles: the four groups (module docstring) and what follows."""

    uses: Uses
    options: Options
    limits: Limits = Limits()
    switches: Switches = Switches()

    @classmethod
    def of(cls, **flat) -> Features:
        """Features from field names of any group, e.g. ``Features.of(bounces=2, bvh=False)``."""
        g = _split(flat)
        return cls(Uses(**g["uses"]), Options(**g["options"]), Limits(**g["limits"]),
                   Switches(**g["switches"]))

    def replace(self, **flat) -> Features:
        """A copy with the named fields (of any group) changed."""
        g = _split(flat)
        return Features(*(dataclasses.replace(getattr(self, name), **g[name]) for name in _GROUPS))

    def everything(self) -> Features:
        """The uber-shader: every optional code path compiled in (bounces stay as given), path
        continuation included where the driver limits loops (a BVH loop may now run)."""
        return self.replace(uber=True, sampling="mis", russian_roulette=True, continuation=True)

    @property
    def compiled(self) -> Uses:
        """The scene's uses as the program compiles them: all of them under the uber switch."""
        return self.uses.everything() if self.switches.uber else self.uses

    # The program as compiled, read by the host (pack.py, render.py): one name per question.
    bounces = property(lambda self: self.options.bounces)
    sampler = property(lambda self: self.options.sampler)
    clamp = property(lambda self: self.options.clamp)
    variance = property(lambda self: self.options.variance)
    aov = property(lambda self: self.options.aov)
    loop_limit = property(lambda self: self.limits.loop_limit)
    compute = property(lambda self: self.switches.compute)
    wavefront = property(lambda self: self.switches.wavefront)
    bvh = property(lambda self: self.compiled.bvh)
    bvh_dense = property(lambda self: self.compiled.bvh_dense)
    textures = property(lambda self: self.compiled.textures)
    normal_maps = property(lambda self: self.compiled.normal_maps)
    opacity = property(lambda self: self.compiled.opacity)
    smooth_normals = property(lambda self: self.compiled.smooth_normals)
    material_texels = property(lambda self: self.compiled.material_texels)

    @property
    def nee(self) -> bool:
        """Light sampling is compiled in (needs an emitter and a bounce; off for BSDF-only)."""
        return self.compiled.lights and self.bounces >= 1 and self.switches.sampling != "bsdf"

    mis = property(lambda self: self.nee and self.switches.sampling == "mis")
    # issue #25: light-directed distances along medium segments (mcpt/shading/medium.py)
    equiangular = property(lambda self: equiangular_used(self.compiled, self.nee, self.switches.equiangular))
    rr = property(lambda self: self.switches.russian_roulette and self.bounces > RR_START)

    @property
    def random_dims(self) -> int:
        """Random numbers per pixel per pass: the camera jitter plus each bounce's share."""
        return (dims_for(self.bounces, self.compiled.thin_lens)
                + medium_dims(self.bounces, self.compiled.medium, self.equiangular))

    @property
    def continues(self) -> bool:
        """Paths are split across draws (glsl/path_state.glsl): only where loops are capped and a
        path can outrun a draw's share (or the uber-shader's BVH loop may), unless switched off."""
        return (self.switches.continuation and self.limits.loop_limit > 0 and not self.switches.wavefront
                and (self.limits.long_paths or self.switches.uber))

    @property
    def uploads_random(self) -> bool:
        """The independent sampler uploads its numbers every pass; sobol computes them."""
        return self.options.sampler == "independent"

    @property
    def key(self) -> tuple:
        """The program cache key: every field of the program as compiled, by name."""
        groups = (self.compiled, self.options, self.limits, self.switches)
        return tuple(sorted(item for g in groups for item in asdict(g).items()))

    def defines(self) -> dict[str, int]:
        b, u, o = int, self.compiled, self.options
        written = u.written_out
        return {
            "MCPT_BOUNCES": o.bounces,
            "MCPT_RAND_DIMS": self.random_dims,
            "MCPT_SAMPLER_SOBOL": b(o.sampler == "sobol"),
            "MCPT_SOBOL_JOINT": b(o.sampler == "sobol" and joint_used(o.bounces)),
            **layout_defines(),
            "MCPT_NEE": b(self.nee),
            "MCPT_MIS": b(self.mis),
            "MCPT_LIGHTS": b(u.lights),
            "MCPT_SINGLE_LIGHT": b(u.single_light),
            "MCPT_LIGHT_STEPS": u.light_steps,
            "MCPT_LIGHT_AREA": b(u.area_lights),
            "MCPT_LIGHT_POINT": b(u.point_lights),
            "MCPT_LIGHT_SPOT": b(u.spot_lights),
            "MCPT_LIGHT_DIRECTIONAL": b(u.directional_lights),
            "MCPT_LIGHT_SUN": b(u.sun_lights),
            "MCPT_LIGHT_ENV": b(u.environment),
            "MCPT_ENVMAP": b(u.environment and u.envmap),
            "MCPT_RR": b(self.rr),
            "MCPT_RR_START": RR_START,
            "MCPT_BVH": b(u.bvh),
            "MCPT_BVH_DENSE": b(u.bvh and u.bvh_dense),
            "MCPT_TRI_CONST": written,
            "MCPT_TRI_FIRST": u.tri_first if written else 0,
            "MCPT_BVH_START": u.bvh_start if written and u.bvh else 0,
            "MCPT_VERT_COUNT": len(u.vert_addr) if written else 0,
            "MCPT_SPHERES": u.spheres,
            "MCPT_MAT_DIFFUSE": b(u.diffuse),
            "MCPT_MAT_CONDUCTOR": b(u.conductor),
            "MCPT_MICROFACET": b(u.microfacet),
            "MCPT_BECKMANN": b(u.microfacet and u.beckmann),
            "MCPT_SEPARABLE_MASKING": b(u.microfacet and u.separable_masking),
            "MCPT_MAT_DIELECTRIC": b(u.dielectric),
            "MCPT_ABSORPTION": b(u.dielectric and u.absorption),
            "MCPT_MAT_PLASTIC": b(u.plastic),
            "MCPT_MAT_ROUGH_DIELECTRIC": b(u.rough_dielectric),
            "MCPT_MAT_THIN_DIELECTRIC": b(u.thin_dielectric),
            "MCPT_MAT_ROUGH_PLASTIC": b(u.rough_plastic),
            "MCPT_MAT_METALROUGH": b(u.metalrough),
            "MCPT_METALROUGH_SPECULAR": b(u.metalrough and u.metalrough_specular),
            "MCPT_TRANSMISSION": b(u.transmission),
            "MCPT_DELTA": b(u.delta),
            "MCPT_MAT_TEXELS": u.material_texels,
            "MCPT_SPECULAR_WEIGHTS": b(u.specular_weights),
            "MCPT_SPEC_TEXEL": u.spec_texel,
            "MCPT_TEXTURES": b(u.textures),
            "MCPT_EMISSION_TEXTURES": b(u.textures and u.emission_textures),
            "MCPT_FLOAT_TEXTURES": b(u.textures and u.float_textures),
            "MCPT_ROUGHNESS_TEXTURES": b(u.textures and u.roughness_textures),
            "MCPT_SMOOTH_NORMALS": b(u.smooth_normals),
            "MCPT_FRESNEL_COMPLEX": b(u.conductor and u.fresnel_complex),
            "MCPT_ONE_SIDED": b(u.one_sided),
            "MCPT_NORMAL_MAPS": b(u.normal_maps),
            "MCPT_OPACITY": b(u.opacity),
            "MCPT_CAMERA_MOVES": b(u.camera_moves),
            "MCPT_FILTER": u.pixel_filter,
            "MCPT_THIN_LENS": b(u.thin_lens),
            "MCPT_ORTHO": b(u.orthographic),
            "MCPT_MEDIUM": b(u.medium),
            "MCPT_MEDIUM_INTERIOR": b(u.medium and u.interior_media),
            "MCPT_MEDIUM_EQUIANGULAR": b(self.equiangular),
            "MCPT_DIM_MEDIUM": dims_for(o.bounces, u.thin_lens),  # after the bounces' (and lens') numbers
            "MCPT_CLAMP": b(o.clamp),
            "MCPT_VARIANCE": b(o.variance),
            "MCPT_ALPHA": b(o.alpha and o.variance),
            "MCPT_AOV": b(o.aov),
            "MCPT_LOOP_LIMIT": self.limits.loop_limit,
            "MCPT_COUNTERS": b(self.switches.counters),
            "MCPT_CONTINUE": b(self.continues),
            "MCPT_COMPUTE": b(self.switches.compute),
            "MCPT_WAVE": b(self.switches.wavefront),
        }

    def preamble(self) -> str:
        defines = self.defines()
        lines = [f"#define {k} {v}" for k, v in defines.items()]
        if defines["MCPT_COUNTERS"]:
            # Ballots count a SIMD batch's active lanes (glsl/bvh.glsl batch_share); before any
            # code, as GLSL wants. A driver without them warns and the count reads unknown.
            lines[:0] = ["#extension GL_ARB_shader_ballot : enable",
                         "#extension GL_ARB_gpu_shader_int64 : enable"]
        if defines["MCPT_VERT_COUNT"]:
            u = self.compiled
            lines.append(vertex_tables(u.vert_addr, u.tri_vert_ids, u.vert_pos))
        return "\n".join(lines)


def derive(*, bounces: int, n_triangles: int, n_emissive: int, material_types: set[str],
           rough: bool = False, absorption: bool = False, textures: bool = False,
           smooth_normals: bool = False, fresnel_complex: bool = False, one_sided: bool = False,
           normal_maps: bool = False, opacity: bool = False,
           sampling: str = "mis", russian_roulette: bool = True,
           bvh: bool | None = None, clamp: bool = False, variance: bool = False, aov: bool = False, alpha: bool = False,
           loop_limit: int = 0, counters: bool = False, bvh_dense: bool = False,
           sampler: str = "sobol", continuation: bool = True, lights: dict | None = None,
           medium: bool = False, interior_media: bool = False, compute: bool = False,
           wavefront: bool = False) -> Features:
    """Features of a scene from its counts; the one place these decisions are made.

    ``sampling``, ``russian_roulette``, ``counters``, ``continuation``: :class:`Switches`;
    ``material_types``: the material types some triangle uses; ``rough``: some conductor has
    roughness >= 0.001; ``absorption``: some dielectric absorbs; ``textures`` / ``smooth_normals``:
    some used material has an albedo texture / smooth shading normals; ``fresnel_complex``: some
    conductor has ``fresnel: conductor``; ``one_sided``: some material has ``two_sided: false``;
    ``lights``: the light fields of Uses (mcpt/shading/lights.py light_uses; absent: ``n_emissive``
    area lights).
    """
    use_bvh = (n_triangles >= BVH_MIN_TRIANGLES) if bvh is None else bvh
    tri_const = n_triangles if not use_bvh and 0 < n_triangles <= TRI_CONST_MAX else 0
    has = material_types.__contains__
    return Features.of(
        # what the scene uses
        **(lights or count_uses(n_emissive)), bvh=use_bvh, bvh_dense=bvh_dense,
        tri_const=tri_const, diffuse=has("diffuse"), conductor=has("conductor"),
        microfacet=has("conductor") and rough, dielectric=has("dielectric"),
        absorption=has("dielectric") and absorption, plastic=has("plastic"), textures=textures,
        smooth_normals=smooth_normals, fresnel_complex=has("conductor") and fresnel_complex,
        one_sided=one_sided, normal_maps=normal_maps, opacity=opacity, medium=medium,
        interior_media=interior_media,
        # what the render is asked for; what the driver limits; the switches
        bounces=bounces, sampler=sampler, clamp=clamp, variance=variance or alpha, aov=aov, alpha=alpha,
        loop_limit=loop_limit, long_paths=needs_continuation(loop_limit, bounces, n_triangles,
                                                             traced=not tri_const, n_lights=n_emissive),
        sampling=sampling, russian_roulette=russian_roulette, counters=counters, continuation=continuation,
        compute=compute or wavefront, wavefront=wavefront)


def for_world(world, *, bounces: int | None = None, **flags) -> Features:
    """The features of a built world (mcpt/shapes/world.py): what its used materials need;
    ``flags``: :func:`derive`'s options, limits and switches by name (e.g. ``loop_limit=``)."""
    mt = world.materials
    # The distinct used ids stand for the 10^6 per-triangle ids: every table method below asks
    # only which ids are used (MaterialTable.used), so one pass over them serves all 16 (issue #23).
    ids = np.asarray(mt.used(world.material_ids), np.int64)
    used = {mt.types[i] for i in ids}
    f = derive(
        bounces=world.scene.render.bounces if bounces is None else bounces,
        n_triangles=world.n_triangles, n_emissive=world.lights.entries, material_types=used,
        lights=light_uses(world.lights), alpha=world.scene.render.transparent,
        rough=mt.rough(ids), absorption=mt.absorbing(ids), textures=mt.textured(ids),
        smooth_normals=mt.smooth_shaded(ids), fresnel_complex=mt.complex_fresnel(ids),
        one_sided=mt.one_sided_used(ids), normal_maps=mt.normal_mapped(ids),
        opacity=mt.cut_out(ids), **medium_uses(world), **{"bvh_dense": world.bvh.dense, **flags})
    f = f.replace(**microfacet.uses(mt, ids), **thindielectric.uses(mt, ids), **metalrough.uses(mt, ids),
                  **camera_uses(world.scene.camera), **emission_texture.uses(mt, ids),
                  **specular_weights.uses(mt, ids), **roughness_texture.uses(mt, ids))
    first = 0
    if f.uses.bvh and not f.uses.bvh_dense:
        first, start = world.bvh.large_tail()
        if 0 < world.n_triangles - first <= TRI_CONST_MAX and first > 0:
            f = f.replace(tri_const=world.n_triangles - first, tri_first=first, bvh_start=start)
    if f.uses.written_out:
        addr, tv = shared_vertices(world.tris[first:])
        f = f.replace(vert_addr=tuple(int(a) + 3 * first for a in addr),
                      tri_vert_ids=tuple(int(i) for i in tv.ravel()),
                      vert_pos=vertex_bits(world.tris[first:], addr))
    if any(getattr(t, "is_float", False) for t in getattr(world, "textures", ())):  # issue #22
        f = f.replace(float_textures=True)
    if camera_moves(world.scene):  # issue #26 (mcpt/scene/animation.py)
        f = f.replace(camera_moves=True)
    if world.n_spheres:
        f = f.replace(spheres=world.n_spheres)
    return f
