"""Thin dielectric (GLSL side: glsl/bsdf_thindielectric.glsl): a pane whose two faces are close
enough that light leaves where it entered, unrefracted, as Mitsuba 3's ``thindielectric``. The
table row uses the ``ior`` column (the pane's index relative to the air around it).

:func:`reflectance` is the summed reflectance of the pane in float64 (the shader's twin).
"""

from __future__ import annotations

import numpy as np

from .materials import fresnel_dielectric


def reflectance(cos_i, ior: float) -> np.ndarray:
    """R' = R + T^2 R / (1 - R^2) = 2R / (1 + R): one face's Fresnel R, then every path that
    bounces an even number of times between the faces before leaving on the incident side."""
    r = fresnel_dielectric(np.abs(np.asarray(cos_i, np.float64)), ior)
    return 2.0 * r / (1.0 + r)


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses field: some used material is a thin dielectric."""
    return {"thin_dielectric": any(table.types[i] == "thindielectric" for i in table.used(ids))}
