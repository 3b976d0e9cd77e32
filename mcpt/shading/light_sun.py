"""Sun disks: directional lights with an angular diameter (GLSL side: glsl/light_sun.glsl; the
light itself is an entry of the punctual table, mcpt/shading/light_punctual.py, kind "sun").

Next-event estimation samples the disk's cone uniformly (pdf 1 / solid angle); a ray that leaves
the scene inside the cone sees the disk's radiance, MIS-weighted against that pdf. The escape
test reads the suns from small uniform arrays (at most MAX_SUNS), since every escaping ray checks
each of them.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import McptError

MAX_SUNS = 4


class SunError(McptError, ValueError):
    """More sun disks than the shader's escape test holds."""


def sun_uniforms(lights, where: str) -> dict:
    """``u_sun_count``, ``u_sun_dir`` (direction to the sun, cos of its half-angle) and ``u_sun_le``
    (radiance, pick probability / solid angle: the NEE density of a direction on the disk)."""
    first = lights.count
    suns = [(i, p) for i, p in enumerate(lights.punctual) if p.kind == "sun"]
    if len(suns) > MAX_SUNS:
        raise SunError(f"{where}: {len(suns)} lights with an angular diameter; mcpt takes at most {MAX_SUNS}")
    dirs = np.zeros((MAX_SUNS, 4), np.float32)
    les = np.zeros((MAX_SUNS, 4), np.float32)
    for k, (i, p) in enumerate(suns):
        dirs[k] = (*(-p.axis), math.cos(p.half_angle))
        les[k] = (*p.value, float(lights.pmf[first + i]) / p.solid_angle)
    return {"u_sun_count": len(suns), "u_sun_dir": [tuple(map(float, r)) for r in dirs],
            "u_sun_le": [tuple(map(float, r)) for r in les]}
