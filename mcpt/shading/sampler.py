"""Random numbers of a path: their layout (the one definition) and both samplers.

Layout (the shader reads it from the MCPT_DIM* defines, see :func:`layout_defines`)::

    dim 0, 1                 the film position in the pixel (uniform: box; or the pixel filter's)
    dim 2 + 6 (k - 1) + ...  bounce k = 1..bounces:
        + 0 spare (see below),  + 1, + 2 light choice and point on it,  + 3, + 4 BSDF direction,
        + 5 roulette
    dim 2 + 6 bounces + 0, 1  the point on the lens (thin lens only, issue #22)

i.e. ``DIMS_CAMERA + DIMS_PER_BOUNCE * (k - 1) + DIM_*``. The lens comes last so that a pinhole
path's numbers stay where they were (a pinhole render is bit-identical with or without it). The
same six numbers serve every material (glsl/materials.glsl), so no material feature adds
dimensions: light sampling picks the light with + 1 and places the point on it with + 1 rescaled
within the pick's cdf bucket and + 2 (Mitsuba 3's sample reuse: the 2D sample then stays stratified
over all emitters together; a separate pick number left each triangle of a quad light a random
subset of the net, relMSE x1.02-1.03 at equal spp, issue #23, bench/sampler-quality.md), so + 0 is
read only by media's equiangular pick and the rough dielectric (below). A vertex without a light
sample (mirror, glass) leaves + 0..2 unread; glass picks reflection or refraction with + 3 (its
directions are fixed); plastic picks its lobe with + 3 and rescales it to [0, 1) for the diffuse
direction ((u - p) / (1 - p) is uniform given u >= p: the
"sample reuse" of pbrt-v4), which costs a few of the 24 bits, far below what a direction needs. A
rough dielectric needs a third number after its microfacet normal (reflect or refract by the
Fresnel of that facet): it reads + 0 (glsl/sampler.glsl rand_bsdf), which surface light sampling
no longer reads; in a medium, the equiangular light pick may share it, and as the light sample
and the BSDF sample are separate terms of the vertex's estimate, each unbiased on its own, sharing
a number changes their correlation, never the expected value; scenes without rough glass read
nothing more. Because the layout does not depend on the sampling mode either, NEE-only,
BSDF-only and MIS renders with one seed draw the same BSDF directions (the tests compare their
variances that way).

Samplers (``--sampler``, features.SAMPLERS):

``sobol`` (default) padded, Owen-scrambled Sobol' computed in the shader from hashes of (seed,
pixel, dim) and the sample index (mcpt/shading/sobol.py, glsl/sobol.glsl): no upload, no host work per
pass, and 2D pairs stratified across samples (faster convergence: relMSE x0.59 at equal spp on
the Cornell box, bench/samplers.py); the three pairs of ``JOINT_DIMS`` are one 6-D Sobol' point,
stratified together. A draw may take several samples (path regeneration).

``independent``: the numbers below, generated on the host for every pass and uploaded (one
``R32F`` buffer texture, float32 in [0, 1), 24 random bits each, ``D = features.random_dims``)::

    index = dim * P + pixel,   P = pixels in the tile,
                               pixel = row_in_tile * tile_width + column_in_tile (rows from the top)

so a pixel reads only its own ``D`` numbers, each dimension of its path gets its own number, and no
two pixels or bounces share one. Dimension-major order makes neighbouring pixels, shaded side by
side in one SIMD batch (llvmpipe) or warp (GPU), read neighbouring addresses. Pass ``p`` of tile
``t`` draws from its own PCG64 stream seeded by ``SeedSequence([seed, t, p])``: passes never reuse
numbers (the thesis's code did), the same seed gives the same image, and any pass can be regenerated
on its own (no state to carry).

Cost: about 8 ms for 256 x 256 x 50 numbers on this 2-core machine, written into one
preallocated array (fresh 13 MB allocations each pass cost 5x more in page faults); the render
result reports generation seconds beside render seconds (bench/run.py prints the ratio).
"""

from __future__ import annotations

import numpy as np

# The layout above, defined once (features.py emits it as defines, glsl/sampler.glsl reads them).
DIMS_CAMERA = 2        # camera jitter
DIMS_PER_BOUNCE = 6    # spare, light choice + point (2), BSDF direction (2), roulette
DIM_LIGHT_PICK = 0     # offsets inside one bounce's share; + 0: media's equiangular light pick
DIM_LIGHT_UV = 1       # light choice (x, reused) and point on the light
DIM_BSDF_UV = 3
DIM_RR = 5
DIMS_LENS = 2          # thin lens: the point on the aperture, after the last bounce

#: The path dimensions the sobol sampler draws together from one 6-D Owen-scrambled Sobol' point
#: instead of three padded 2-D points (mcpt/shading/sobol.py, issue #23): the BSDF direction at the
#: first hit, the light point at the second and the BSDF direction there. Their joint strata are
#: what indirect light varies over most: relMSE x spp at 256 spp x0.89 on the Cornell box and x0.86
#: on the 100k sphere against padded pairs (bench/sampler-quality.md), where padding all of them
#: alike had left mcpt level with Mitsuba's multijitter.
JOINT_DIMS = (DIMS_CAMERA + DIM_BSDF_UV,
              DIMS_CAMERA + DIMS_PER_BOUNCE + DIM_LIGHT_UV,
              DIMS_CAMERA + DIMS_PER_BOUNCE + DIM_BSDF_UV)


def joint_used(bounces: int) -> bool:
    """Whether paths of ``bounces`` read the joint point's second hit; with one bounce the first
    hit's pair alone is as good padded, and the shader compiles the joint point out."""
    return int(bounces) >= 2


def dims_for(bounces: int, lens: bool = False) -> int:
    """Random numbers one path of ``bounces`` scattering events may read (``lens``: thin lens)."""
    return DIMS_CAMERA + DIMS_PER_BOUNCE * int(bounces) + (DIMS_LENS if lens else 0)


def layout_defines() -> dict[str, int]:
    return {"MCPT_DIMS_CAMERA": DIMS_CAMERA, "MCPT_DIMS_PER_BOUNCE": DIMS_PER_BOUNCE,
            "MCPT_DIM_LIGHT_PICK": DIM_LIGHT_PICK, "MCPT_DIM_LIGHT_UV": DIM_LIGHT_UV,
            "MCPT_DIM_BSDF_UV": DIM_BSDF_UV, "MCPT_DIM_RR": DIM_RR,
            **{f"MCPT_SOBOL_JOINT{t}": d for t, d in enumerate(JOINT_DIMS)}}


class RandomNumbers:
    """Per-pass random numbers for a tile of ``n_pixels`` pixels and ``dims`` dimensions."""

    def __init__(self, seed: int, n_pixels: int, dims: int, tile: int = 0):
        self.seed, self.n_pixels, self.dims, self.tile = int(seed), int(n_pixels), int(dims), int(tile)

    @property
    def count(self) -> int:
        return self.n_pixels * self.dims

    @property
    def nbytes(self) -> int:
        return 4 * self.count

    def fill(self, pass_index: int, out: np.ndarray) -> np.ndarray:
        """Write pass ``pass_index``'s numbers into ``out[:count]`` (float32, uniform in [0, 1))."""
        ss = np.random.SeedSequence([self.seed, self.tile, int(pass_index)])
        rng = np.random.Generator(np.random.PCG64(ss))
        rng.random(out=out[: self.count], dtype=np.float32)
        return out

    def for_pass(self, pass_index: int) -> np.ndarray:
        """A new array with pass ``pass_index``'s numbers (tests and tools; render() uses fill)."""
        return self.fill(pass_index, np.empty(self.count, np.float32))
