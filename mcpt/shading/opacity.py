"""Opacity cut-outs (GLSL side: glsl/opacity.glsl): where a material's opacity texture says a
surface is not there, rays pass through it.

The opacity at a hit is the luminance (Rec. 709 weights) of the material's opacity texture there
(an image, sRGB-decoded or linear, or a checkerboard). With a ``cutoff`` (glTF alphaMode MASK,
OBJ-style cut-outs) the surface is absent where opacity < cutoff; without one (glTF BLEND,
Mitsuba's ``mask``) it is absent with probability 1 - opacity, decided by a hash of the ray and
the triangle (no sampler state: the decision is part of the traversal, so closest-hit and shadow
rays agree, and one --seed still reaches every number). The test runs inside traversal (the
any-hit test of bvh.glsl), for every ray: camera, BSDF and shadow rays all pass through
transparent texels, so a cut-out lets light through exactly where it lets the eye through.

It rides on the normal maps' per-material texel (mcpt/shading/normal_map.py): .w the opacity
texture id (0xffffffff: opaque), flags bit 2 "has a cutoff", flags bits 16-31 the cutoff x 65535.
"""

from __future__ import annotations

FLAG_CUTOFF = 4


def opacity_bits(cutoff: float | None) -> int:
    """The flag bits of a cutoff (None: stochastic)."""
    if cutoff is None:
        return 0
    return FLAG_CUTOFF | (int(round(min(max(cutoff, 0.0), 1.0) * 65535)) << 16)
