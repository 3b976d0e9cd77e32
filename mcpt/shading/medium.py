"""The scene's participating medium on the GPU (issue #25; scene side: mcpt/scene/medium.py; GLSL:
glsl/medium.glsl free-flight sampling and transmittance, glsl/medium_scatter.glsl the medium
vertex, glsl/phase_hg.glsl the phase function).

A scene-wide homogeneous medium is three uniforms (no table): ``u_medium_sigma_t`` and
``u_medium_sigma_s`` (RGB, 1 / world unit) and ``u_medium_g``. A scene without one compiles the
code out (MCPT_MEDIUM 0); the uber-shader (``--features all``) gets zeros, which make every ray
pass with weight 1. Random numbers: the free-flight distance of the segment to hit k reads
dimension ``dims_for(bounces) + k - 1`` (a block after the bounces' own, so scenes without a medium
keep their layout: mcpt/shading/sampler.py); the medium vertex reads bounce k's numbers.
"""

from __future__ import annotations


def medium_used(scene) -> bool:
    """The scene has a medium (the MCPT_MEDIUM feature)."""
    return getattr(scene, "medium", None) is not None


def medium_dims(bounces: int, medium: bool) -> int:
    """Random dimensions the medium adds: one free-flight distance per bounce."""
    return int(bounces) if medium else 0


def medium_uniforms(medium) -> dict:
    """The uniforms of glsl/medium.glsl for ``medium`` (None: an empty medium, the uber-shader's)."""
    if medium is None:
        return {"u_medium_sigma_t": (0.0, 0.0, 0.0), "u_medium_sigma_s": (0.0, 0.0, 0.0), "u_medium_g": 0.0}
    sigma_t, sigma_s = medium.coefficients
    return {"u_medium_sigma_t": tuple(float(x) for x in sigma_t),
            "u_medium_sigma_s": tuple(float(x) for x in sigma_s), "u_medium_g": float(medium.g)}
