"""A participating medium as the scene file states it (issue #25; GPU side: mcpt/shading/medium.py
<-> glsl/medium.glsl, glsl/medium_scatter.glsl, glsl/phase_hg.glsl).

``medium:`` at the top of a scene fills the whole scene with a homogeneous medium (fog, haze,
smoke; Mitsuba 3's ``homogeneous`` medium referenced by the sensor). Coefficients are per unit of
world length (1 / world unit), linear RGB or one number for all three channels:

* ``sigma_a`` (absorption) and ``sigma_s`` (scattering), or
* ``albedo`` (single-scattering albedo sigma_s / sigma_t, in [0, 1]) and ``density`` (sigma_t,
  the extinction), as Mitsuba 3's ``homogeneous`` takes ``albedo`` and ``sigma_t``;
* ``scale`` multiplies the coefficients (Mitsuba's ``scale``);
* ``g``: the Henyey-Greenstein phase function's mean cosine, in (-1, 1): 0 isotropic, > 0 forward
  (Mitsuba 3's ``hg``; default 0, Mitsuba's ``isotropic``).

Mean free path = 1 / sigma_t world units: a fog of density 0.1 in a 10-unit room scatters a camera
ray about once on its way across.

An interior medium behind an index-matched boundary (a dielectric of ior 1, Mitsuba's ``null``
BSDF) with a delta light (point, spot, directional without a disk) is refused
(:func:`check_delta_lights`): mcpt's shadow rays stop at every dielectric, so only light sampling
could carry such a light across the boundary and it never does; the medium would be unlit by it and
cast a black shadow where Mitsuba's volpath (whose shadow rays pass null BSDFs, src/integrators/
volpath.cpp ``sample_emitter``: ``eval_null_transmission``) lights it and casts a transmittance
shadow. Emissive meshes, environments and sun disks are right: a phase or BSDF sample passes the
boundary (a delta bounce, so what it finds counts with MIS weight 1). Behind glass (ior != 1)
Mitsuba's dielectric blocks shadow rays too: both leave the medium unlit by delta lights.
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from .diagnostics import FieldError
from .fields import Albedo, Radiance, StrictModel, scalar_to_vec3

#: A coefficient: one number or RGB, each >= 0 and finite (1 / world unit).
Coefficient = Annotated[Radiance, BeforeValidator(scalar_to_vec3)]
#: Largest extinction, 1 / world unit: beyond it a free flight is shorter than float32 positions
#: can step (their spacing near 1 is 1.2e-7), so every path would stall where it starts.
MAX_SIGMA_T = 1e6
_G = Annotated[float, Field(gt=-1.0, lt=1.0)]


def delta_light(kind: str, angular_diameter_deg) -> bool:
    """A light that only light sampling finds (no ray hits it): point, spot, a directional without
    a disk (mcpt/scene/lights.py)."""
    return kind in ("point", "spot") or (kind == "directional" and not angular_diameter_deg)


def blocked_reason(kind: str, which: str) -> str:
    """Why a ``kind`` delta light (``which``: where it is) and a medium behind an ior-1 boundary are
    refused (module docstring)."""
    return (f"the {kind} light {which} cannot cross this ior-1 boundary (mcpt's shadow rays stop there, "
            "Mitsuba's pass a null BSDF): it would not light the medium nor shine through it; use an "
            "emissive mesh, an environment or a sun disk (angular_diameter_deg)")


def check_delta_lights(scene) -> None:
    """Refuse a used dielectric of ior 1 holding an interior medium in a scene with a delta light."""
    delta = [(i, light.type) for i, light in enumerate(scene.lights)
             if delta_light(light.type, light.angular_diameter_deg)]
    if not delta:
        return
    used = {mesh.material for mesh in scene.meshes}
    for name, mat in scene.materials.items():
        if name in used and mat.type == "dielectric" and mat.interior is not None and mat.ior == 1.0:
            i, kind = delta[0]
            raise FieldError(("materials", name, "interior"), blocked_reason(kind, f"(lights[{i}])"))


class Medium(StrictModel):
    """A homogeneous medium (module docstring)."""

    sigma_a: Coefficient | None = None
    """Absorption coefficient, 1 / world unit (RGB or one number)."""
    sigma_s: Coefficient | None = None
    """Scattering coefficient, 1 / world unit (RGB or one number)."""
    albedo: Annotated[Albedo, BeforeValidator(scalar_to_vec3)] | None = None
    """Single-scattering albedo sigma_s / sigma_t (with ``density``)."""
    density: Coefficient | None = None
    """Extinction coefficient sigma_t, 1 / world unit (with ``albedo``)."""
    scale: Annotated[float, Field(gt=0.0)] = 1.0
    """Factor on the coefficients (Mitsuba's ``scale``)."""
    g: _G = 0.0
    """Henyey-Greenstein mean cosine, in (-1, 1)."""

    @model_validator(mode="after")
    def _check(self) -> Medium:
        pair_a = self.sigma_a is not None or self.sigma_s is not None
        pair_b = self.albedo is not None or self.density is not None
        if pair_a == pair_b:
            raise FieldError(("sigma_s",), "give sigma_a and sigma_s, or albedo and density (one pair)")
        if pair_b and (self.albedo is None or self.density is None):
            raise FieldError(("density" if self.density is None else "albedo",),
                             "albedo and density go together")
        sigma_t = self.coefficients[0]
        if not np.all(np.isfinite(sigma_t)):
            raise FieldError(("scale",), "the coefficients times scale overflow float32")
        if float(np.max(sigma_t)) <= 0.0:
            raise FieldError(("sigma_s" if pair_a else "density",), "the medium is empty (sigma_t = 0)")
        if float(np.max(sigma_t)) > MAX_SIGMA_T:
            raise FieldError(("sigma_s" if pair_a else "density",),
                             f"sigma_t {float(np.max(sigma_t)):.3g} per world unit: a mean free path below "
                             f"{1 / MAX_SIGMA_T:g} world units stops every path at the camera")
        return self

    @property
    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(sigma_t, sigma_s), float32 RGB, 1 / world unit, scale applied."""
        with np.errstate(over="ignore"):
            if self.density is not None:
                sigma_t = np.float32(self.scale) * np.asarray(self.density, np.float32)
                return sigma_t, sigma_t * np.asarray(self.albedo, np.float32)
            sigma_s = np.float32(self.scale) * np.asarray(self.sigma_s or (0, 0, 0), np.float32)
            sigma_a = np.float32(self.scale) * np.asarray(self.sigma_a or (0, 0, 0), np.float32)
            return sigma_a + sigma_s, sigma_s
