"""Point, spot and directional lights (GLSL side: glsl/light_punctual.glsl; scene side:
mcpt/scene/lights.py). Delta lights: found by next-event estimation only, weight 1, no MIS.

Each takes PUNCTUAL_TEXELS texels (float32 bits) after the light table's entries
(mcpt/shading/lights.py)::

    0: position (camera-relative, world units), 0
    1: intensity (W sr^-1) or, directional, irradiance (W m^-2), RGB; 0
    2: unit axis: the direction the light travels (spot axis, sun direction); 0
    3: spot: cos(cutoff), cos(beam), cutoff (rad), 1 / (cutoff - beam) (rad^-1; 0 if equal);
       sun disk: cos(half-angle), 1 / its solid angle (sr^-1), 0, 0

A directional light with an angular diameter (kind "sun", mcpt/shading/light_sun.py) is not a
delta light: texel 1 holds its radiance E / (pi sin^2 alpha), alpha the half-angle.

Powers for the selection distribution are flux / pi (the area lights' unit): a point light
4 I, a spot 2 (1 - cos theta_m) I with theta_m halfway between beam and cutoff (the cone it
lights, roughly), a directional light E r^2 with r the scene's bounding radius (the flux through
the scene's disk). Luminance of the RGB.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

PUNCTUAL_TEXELS = 4
KIND_OF = {"point": 1, "spot": 2, "directional": 3, "sun": 5}  # glsl/lights.glsl LIGHT_*
_LUM = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class Punctual:
    kind: str                 # "point", "spot", "directional"
    position: np.ndarray      # (3,) camera-relative, world units (directional: unused)
    value: np.ndarray         # (3,) intensity W/sr, or irradiance W/m^2 (directional)
    axis: np.ndarray          # (3,) unit direction the light travels (point: unused)
    cutoff: float = 0.0       # spot cutoff half-angle, rad
    beam: float = 0.0         # spot beam half-angle, rad
    power: float = 0.0        # flux / pi, for light selection
    half_angle: float = 0.0   # sun disk: its angular radius, rad

    @property
    def solid_angle(self) -> float:
        """Sun disk: the solid angle it covers, sr (2 pi (1 - cos alpha), written stably)."""
        return 4.0 * math.pi * math.sin(0.5 * self.half_angle) ** 2

    def texels(self) -> np.ndarray:
        t = np.zeros((PUNCTUAL_TEXELS, 4), np.float32)
        t[0, :3], t[1, :3], t[2, :3] = self.position, self.value, self.axis
        if self.kind == "spot":
            w = self.cutoff - self.beam
            t[3] = (math.cos(self.cutoff), math.cos(self.beam), self.cutoff, 1.0 / w if w > 0 else 0.0)
        if self.kind == "sun":
            t[3, :2] = (math.cos(self.half_angle), 1.0 / self.solid_angle)
        return t


def spot_falloff(cos_theta: np.ndarray, cutoff: float, beam: float) -> np.ndarray:
    """Mitsuba 3's spot profile (src/emitters/spot.cpp falloff_curve): 1 inside the beam, linear
    in angle to 0 at the cutoff, 0 beyond."""
    c = np.asarray(cos_theta, np.float64)
    w = cutoff - beam
    ramp = (cutoff - np.arccos(np.clip(c, -1, 1))) / w if w > 0 else np.zeros_like(c)
    return np.where(c > math.cos(cutoff), np.where(c >= math.cos(beam), 1.0, ramp), 0.0)


def punctual_lights(specs, origin: np.ndarray, radius: float) -> tuple:
    """The scene's lights (mcpt/scene/lights.Light) relative to ``origin`` (the camera), powers
    with the scene's bounding ``radius`` (world units)."""
    out = []
    for s in specs:
        pos = np.zeros(3) if s.position is None else np.asarray(s.position, np.float64) - origin
        value = np.asarray(s.irradiance if s.type == "directional" else s.intensity, np.float64)
        lum = float(value @ _LUM)
        axis = np.zeros(3) if s.type == "point" else s.axis
        cutoff = beam = 0.0
        if s.type == "point":
            power = 4.0 * lum
        elif s.type == "spot":
            cutoff, beam = math.radians(s.cutoff), math.radians(s.beam)
            power = 2.0 * (1.0 - math.cos(0.5 * (cutoff + beam))) * lum
        else:
            power = lum * max(radius, 1e-6) ** 2
        half = math.radians(0.5 * (s.angular_diameter_deg or 0.0))
        if half > 0.0:  # a sun disk: its radiance gives irradiance E facing it (pi L sin^2 alpha)
            out.append(Punctual("sun", pos, value / (math.pi * math.sin(half) ** 2), axis, power=power,
                                half_angle=half))
            continue
        out.append(Punctual(s.type, pos, value, axis, cutoff, beam, power))
    return tuple(out)
