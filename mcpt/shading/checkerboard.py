"""The procedural checkerboard texture (GLSL side: glsl/checkerboard.glsl).

Mitsuba 3's ``checkerboard`` (src/textures/checkerboard.cpp): at the transformed coordinates
(s, t) = to_uv(u, v), ``color0`` where frac(s) > 1/2 and frac(t) > 1/2 agree (both or neither),
``color1`` elsewhere; so the square [0, 1/2)^2 is color0 and the pattern repeats every 1 in s
and t. mcpt evaluates it on its own UVs (v up); the Mitsuba XML mapping folds Mitsuba's v flip
into the transform (mcpt/scene/mitsuba/textures.py), so the squares land where Mitsuba puts them.
(Mitsuba's ``eval_1``, the scalar lookup used for opacities, swaps the two colours: only colour
lookups read this texture here.)

It shares the ``textures`` buffer with the images (mcpt/shading/texture.py): header (first data
texel, 1, 1, FLAG_TRANSFORM | FLAG_CHECKERBOARD), the UV transform's 2 texels, then 2 texels of
float bits: (color0.rgb, 0), (color1.rgb, 0), linear RGB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .texture import FLAG_CHECKERBOARD, FLAG_TRANSFORM, IDENTITY_UV, uv_texels

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Checkerboard:
    color0: RGB = (0.4, 0.4, 0.4)  # Mitsuba's defaults
    color1: RGB = (0.2, 0.2, 0.2)
    uv: tuple = IDENTITY_UV         # 2x3 affine map applied to the UVs first (v up)

    width = 1
    height = 1
    flags = FLAG_TRANSFORM | FLAG_CHECKERBOARD

    def mean_linear(self) -> np.ndarray:
        """The area average (what Mitsuba's mean() gives): half of each colour."""
        return 0.5 * (np.asarray(self.color0, np.float64) + np.asarray(self.color1, np.float64))

    def texels(self) -> np.ndarray:
        colours = np.zeros((2, 4), np.float32)
        colours[0, :3], colours[1, :3] = self.color0, self.color1
        return np.concatenate([uv_texels(self.uv), colours.view(np.uint32)])

    def lookup(self, st: np.ndarray) -> np.ndarray:
        """Reference (float64) at already transformed coordinates st (N, 2)."""
        hi = (st - np.floor(st)) > 0.5
        same = hi[:, 0] == hi[:, 1]
        return np.where(same[:, None], np.asarray(self.color0, np.float64), np.asarray(self.color1, np.float64))
