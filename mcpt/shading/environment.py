"""The environment: the light of rays that leave the scene (GLSL side: glsl/environment.glsl;
scene side: mcpt/scene/lights.py Environment).

A constant environment (Mitsuba 3's ``constant``) has radiance L from every direction. Next-event
estimation samples it uniformly over the sphere (pdf 1 / (4 pi) sr^-1), one entry of the light
table (mcpt/shading/lights.py); a BSDF-sampled ray that escapes finds it and is weighted against
that pdf by the power heuristic. Its power for light selection, in the light table's flux / pi
units, is what crosses the scene's bounding disk: pi r^2 L (Mitsuba's constant emitter weights by
the same bounding sphere).
"""

from __future__ import annotations

import math

import numpy as np

_LUM = np.array([0.2126, 0.7152, 0.0722])


def env_power(env, radius: float) -> float:
    """Selection power (flux / pi) of the scene's environment (0: none), ``radius`` in world units."""
    if env is None:
        return 0.0
    return math.pi * max(radius, 1e-6) ** 2 * float(np.asarray(env.radiance, np.float64) @ _LUM)


def env_uniforms(env, env_pmf: float) -> dict:
    """Uniforms of glsl/environment.glsl."""
    if env is None:
        return {}
    return {"u_env_radiance": tuple(float(c) for c in env.radiance), "u_env_pmf": env_pmf,
            "u_env_visible": int(env.visible)}
