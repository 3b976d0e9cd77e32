"""The environment: the light of rays that leave the scene (GLSL side: glsl/environment.glsl;
scene side: mcpt/scene/lights.py Environment).

Either a constant environment (Mitsuba 3's ``constant``), radiance L from every direction, which
next-event estimation samples uniformly over the sphere (pdf 1 / (4 pi) sr^-1), or an environment
map (Mitsuba 3's ``envmap``: mcpt/shading/envmap.py reads the image and builds its sampling tables,
glsl/envmap.glsl evaluates and samples it). Either way it is one entry of the light table
(mcpt/shading/lights.py); a BSDF-sampled ray that escapes finds it and is weighted against the
density NEE would have given its direction by the power heuristic. Its power for light selection,
in the light table's flux / pi units, is what crosses the scene's bounding disk: pi r^2 times the
luminance averaged over the sphere (pbrt-v4's infinite lights are weighted alike).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import McptError
from .envmap import EnvMap, build_envmap, read_envmap
from .envmap_file import check_envmap_file

_LUM = np.array([0.2126, 0.7152, 0.0722])


class EnvironmentMapError(McptError, ValueError):
    """The scene's environment map cannot be used (the message names the scene key and the file)."""


def load_environment(env, where: str) -> EnvMap | None:
    """The environment map of the scene's ``environment`` (None: none, or a constant one);
    ``where`` (``file:line: environment.file``) starts any refusal."""
    if env is None or env.file is None:
        return None
    try:
        return build_envmap(read_envmap(env.file), env.scale, env.transform.matrix(), name=str(env.file))
    except McptError as exc:
        raise EnvironmentMapError(f"{where}: {exc}") from None


def check_environment_file(env, where: str, buffer_limit: int) -> None:
    """Issue #20: refuse, from its header and before the world is built, a map that the GL
    driver's buffer textures (``buffer_limit``: its GL_MAX_TEXTURE_BUFFER_SIZE, in texels) or this
    machine's memory cannot hold (mcpt/shading/envmap_file.py check_envmap_size); ``where`` as
    :func:`load_environment`'s."""
    if env is None or env.file is None:
        return
    try:
        check_envmap_file(env.file, buffer_limit)
    except McptError as exc:
        raise EnvironmentMapError(f"{where}: {exc}") from None


def env_power(env, envmap: EnvMap | None, radius: float) -> float:
    """Selection power (flux / pi) of the scene's environment (0: none), ``radius`` in world units."""
    if env is None:
        return 0.0
    mean = envmap.mean_radiance_luminance if envmap is not None else float(np.asarray(env.radiance) @ _LUM)
    return math.pi * max(radius, 1e-6) ** 2 * mean


def env_uniforms(env, envmap: EnvMap | None, env_pmf: float) -> dict:
    """Uniforms of glsl/environment.glsl (and glsl/envmap.glsl)."""
    if env is None:
        return {}
    out = {"u_env_pmf": env_pmf, "u_env_visible": int(env.visible)}
    if envmap is not None:
        return {**out, **envmap.uniforms()}
    return {**out, "u_env_radiance": tuple(float(c) for c in env.radiance)}
