"""The light table for next-event estimation (GLSL side: glsl/lights.glsl).

Every light is an entry of ONE selection distribution, picked with probability proportional to
its power: emissive triangles (area lights), punctual lights (mcpt/shading/light_punctual.py:
point, spot, directional) and the environment (mcpt/shading/environment.py). Powers are in the
units of an area light's ``luminance(Le) x area``, i.e. emitted flux / pi (the pi of a Lambertian
emitter is dropped for all alike) -- the thesis sampled a single light triangle.

The table (RGBA32UI, float32 travels as bits): one texel per entry, ``(payload, cdf upper bound,
pmf, kind)``; an area light's payload is its triangle, a punctual light's the texel where its
PUNCTUAL_TEXELS data texels start (after the entries), the environment's 0. With a point sampled
uniformly on the chosen triangle, the density per unit area is ``pmf / area = luminance(Le) /
total power`` for every area light: a per-MATERIAL constant that the material table carries for
MIS (mcpt/shading/materials.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .light_punctual import KIND_OF, PUNCTUAL_TEXELS

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB primaries
KIND_AREA, KIND_ENV = 0, 4  # entry kinds (glsl/lights.glsl LIGHT_*); punctual: light_punctual.KIND_OF


@dataclass(frozen=True)
class Lights:
    triangles: np.ndarray   # (A,) int: triangle index (BVH order) of each area light
    pmf: np.ndarray         # (A + P + E,) float64 over all entries (area, punctual, env), sums to 1
    total_power: float      # sum of the entries' powers (module docstring: flux / pi)
    punctual: tuple = ()    # Punctual lights, after the area entries
    env_power: float = 0.0  # > 0: the environment is the last entry
    kinds: frozenset = field(default=frozenset())  # light types present: "area", "point", ...
    envmap: object = None   # the environment's EnvMap (mcpt/shading/envmap.py), None: constant or none
    areas: np.ndarray = None  # (A,) area of each area light (the per-triangle pdf: emission_texture.py)

    @property
    def count(self) -> int:
        """Emissive triangles (area lights)."""
        return int(self.triangles.size)

    @property
    def entries(self) -> int:
        """Entries of the selection distribution: every light."""
        return int(self.pmf.size)

    @property
    def env_pmf(self) -> float:
        """Probability of picking the environment (0: none)."""
        return float(self.pmf[-1]) if self.env_power > 0 else 0.0

    def pack(self) -> np.ndarray:
        n, a = self.entries, self.count
        out = np.zeros((max(n, 1) + PUNCTUAL_TEXELS * len(self.punctual), 4), np.uint32)
        if n:
            cdf = np.cumsum(self.pmf)
            cdf /= cdf[-1]
            cdf[-1] = np.inf  # u < 1 always lands in a bucket despite rounding
            out[:a, 0] = self.triangles
            out[:n, 1] = cdf.astype(np.float32).view(np.uint32)
            out[:n, 2] = self.pmf.astype(np.float32).view(np.uint32)
        for i, p in enumerate(self.punctual):
            at = max(n, 1) + PUNCTUAL_TEXELS * i
            out[a + i, 0], out[a + i, 3] = at, KIND_OF[p.kind]
            out[at:at + PUNCTUAL_TEXELS] = p.texels().view(np.uint32)
        if self.env_power > 0:
            out[n - 1, 3] = KIND_ENV
        return out


def build_lights(areas: np.ndarray, tri_emission: np.ndarray, punctual: tuple = (),
                 env_power: float = 0.0, envmap=None, tri_power: np.ndarray | None = None) -> Lights:
    """Lights from per-triangle areas (F,) and emitted radiance (F, 3) (triangles in BVH order),
    the punctual lights, the environment's power (0: none) and its map (None: constant);
    ``tri_power``: each triangle's power where emission textures make it more than
    luminance(Le) x area (mcpt/shading/emission_texture.py)."""
    power = (tri_emission @ LUMINANCE) * areas if tri_power is None else tri_power
    idx = np.nonzero(power > 0.0)[0]
    powers = [power[idx], np.array([p.power for p in punctual], np.float64)]
    if env_power > 0:
        powers.append(np.array([env_power]))
    allp = np.concatenate(powers)
    total = float(allp.sum())
    pmf = allp / total if total > 0 else np.zeros(0)
    kinds = {p.kind for p in punctual} | ({"area"} if idx.size else set())
    kinds |= {"environment"} if env_power > 0 else set()
    return Lights(idx.astype(np.int64), pmf, total, tuple(punctual), float(env_power), frozenset(kinds), envmap,
                  np.asarray(areas, np.float64)[idx])


def material_light_pdf_area(emission: np.ndarray, total_power: float) -> np.ndarray:
    """luminance(Le) / total power per material (0 when the scene has no light)."""
    if total_power <= 0:
        return np.zeros(len(emission))
    return (np.asarray(emission, np.float64) @ LUMINANCE) / total_power


#: Up to this many lights the pick's binary search is written out (glsl/lights.glsl light_pick).
WRITTEN_OUT_SEARCH_MAX = 16


def search_steps(entries: int) -> int:
    """Steps of the light pick's binary search written out in the shader: ceil(log2(entries)) for
    2..WRITTEN_OUT_SEARCH_MAX lights, else 0 (one light needs none; more keep the loop)."""
    return (entries - 1).bit_length() if 2 <= entries <= WRITTEN_OUT_SEARCH_MAX else 0


def count_uses(entries: int) -> dict:
    """The fields of mcpt.gpu.features.Uses that the number of light entries decides."""
    return {"lights": entries > 0, "single_light": entries == 1, "light_steps": search_steps(entries)}


def light_uses(lights: Lights) -> dict:
    """The light fields of mcpt.gpu.features.Uses: which light code a scene compiles."""
    k = lights.kinds
    return {**count_uses(lights.entries), "area_lights": "area" in k,
            "point_lights": "point" in k, "spot_lights": "spot" in k,
            "directional_lights": "directional" in k, "sun_lights": "sun" in k, "environment": "environment" in k,
            "envmap": lights.envmap is not None}


def describe_lights(lights: Lights, scene) -> dict:
    """What ``mcpt info`` lists: every light with its parameters and selection probability."""
    out = {"entries": lights.entries, "area (emissive triangles)": lights.count}
    if lights.count:
        out["area pick probability"] = round(float(lights.pmf[:lights.count].sum()), 6)
    for i, spec in enumerate(scene.lights):
        keys = {k: v for k, v in spec.model_dump().items() if v is not None and k != "type"}
        out[f"{spec.type} {i}"] = f"{keys}, pick probability {float(lights.pmf[lights.count + i]):.6g}"
    if lights.env_power > 0:
        env = {k: str(v) if k == "file" else v for k, v in scene.environment.model_dump(exclude_defaults=True).items()}
        if lights.envmap is not None:
            env["texels"] = f"{lights.envmap.width} x {lights.envmap.height}"
        out["environment"] = f"{env}, pick probability {lights.env_pmf:.6g}"
    return out
