"""Bump maps (GLSL side: glsl/bump_map.glsl): a height texture perturbs the shading normal.

Mitsuba 3's ``bumpmap`` (src/bsdfs/bumpmap.cpp): with g = scale * (dh/du, dh/dv), the gradient
of the height texture's bilinear interpolant per unit of u and v (texel differences times the
resolution; its bitmap's eval_1_grad), and the surface's dp/du, dp/dv (per triangle, from its
corners and UVs), the bumped surface has dp/du' = dp/du + n (g_u - n . dp/du) (likewise v), and
its normal is dp/du' x dp/dv', turned to the unbumped normal's side. A texel's height is its
luminance (Rec. 709 weights; a grey image: its value), sRGB-decoded or linear as the texture
says. The bumped normal then follows the rules of normal maps (glsl/normal_map.glsl: no light
leak, the half turn of a back-facing normal and the bump-terminator shadowing, all Mitsuba 3.9.1's).

The buffers are normal maps' (mcpt/shading/normal_map.py): the material's texel holds the height
texture, ``scale`` (world units per unit of height) and flag bit 1.
"""

from __future__ import annotations

import numpy as np

FLAG_BUMP = 2


def bumped_normal(dpdu, dpdv, n, grad, scale: float) -> np.ndarray:
    """Reference (float64): the bumped unit normal for one surface point."""
    dpdu, dpdv, n = (np.asarray(x, np.float64) for x in (dpdu, dpdv, n))
    g = scale * np.asarray(grad, np.float64)
    du = dpdu + n * (g[0] - n @ dpdu)
    dv = dpdv + n * (g[1] - n @ dpdv)
    b = np.cross(du, dv)
    b /= np.linalg.norm(b)
    return -b if b @ n < 0 else b
