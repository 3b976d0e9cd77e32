"""Measured complex indices of refraction of common metals, reduced to linear sRGB (``metal:`` presets
of a conductor with ``fresnel: conductor``; the formula is in glsl/bsdf_conductor.glsl).

Sources of the spectral data (eta(lambda), k(lambda), relative to vacuum ~ air):

* Au, Ag, Cu, Al: the tables pbrt-v4 ships (src/pbrt/util/spectrum.cpp, ``Au_eta`` ... ``Al_k``),
  the same values as Mitsuba's data/ior/<metal>.eta.spd / .k.spd, whose header names their
  source: the luxpop.com optical-constants database.
* Cr: Mitsuba 0.6's data/ior/Cr.eta.spd / Cr.k.spd (luxpop.com: "Cr_llnl_cxro + Cr_palik", i.e.
  LLNL/CXRO and Palik, "Handbook of Optical Constants of Solids", 1985).

Reduction to RGB (what a renderer in RGB mode does, e.g. Mitsuba 3's ``complex_ior_from_file`` in
its RGB variants): each spectrum s(lambda) is weighted by the CIE 1931 2-degree colour-matching
functions under illuminant D65 and normalised so that a constant spectrum stays that constant,

    XYZ = int s D65 (x, y, z) dlambda / int D65 y dlambda,     RGB = M_sRGB XYZ,

on pbrt-v4's 1 nm CIE tables (360-830 nm; the data held constant beyond its ends), M_sRGB the
IEC 61966-2-1 XYZ -> linear sRGB matrix. eta and k are reduced separately, so the RGB reflectance
is an approximation of the spectral one (Au's normal-incidence reflectance comes out
(0.975, 0.804, 0.356) against (1.0, 0.78, 0.34) for the reduced reflectance spectrum).
"""

from __future__ import annotations

#: name -> (eta RGB, k RGB), linear sRGB, dimensionless.
METALS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "Au": ((0.0801, 0.4047, 1.5614), (3.3905, 2.5038, 1.7709)),  # gold
    "Ag": ((0.1285, 0.1235, 0.1509), (4.0649, 3.2863, 2.3917)),  # silver
    "Cu": ((0.1045, 0.9782, 1.2047), (3.2733, 2.5923, 2.3692)),  # copper
    "Al": ((1.4074, 0.9267, 0.5840), (7.7404, 6.6026, 5.3603)),  # aluminium
    "Cr": ((3.6816, 3.0662, 1.8560), (4.3099, 4.4611, 4.1502)),  # chromium
}
