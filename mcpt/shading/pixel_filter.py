"""Pixel (reconstruction) filters by filter importance sampling (GLSL side: glsl/pixel_filter.glsl).

mcpt never splats: each camera sample's offset from its pixel's centre is DRAWN from the filter's
own distribution and the sample adds to that one pixel with weight 1 (filter importance sampling,
Ernst et al. 2006, "Filter importance sampling", IEEE RT; pbrt-v4's FilterSampler). The pixel's
mean is then ``integral f(x - c) L(x) dx / integral f`` -- what Mitsuba's splatting film converges
to -- while the image stays a per-pixel sum: deterministic, bit-identical across resume and the
farm. The filters are Mitsuba 3's (src/rfilters/*.cpp), separable ``f(x) f(y)`` in pixels:

* ``box``: 1 inside ``|x| < 0.5`` (radius 0.5): the uniform jitter of before, compiled without
  any of this (``MCPT_FILTER 0``: today's pixels, bit for bit).
* ``tent`` (``MCPT_FILTER 1``): ``max(0, 1 - |x| / r)``, ``r = radius`` (Mitsuba: 1 px); its inverse
  CDF is a closed form (one square root).
* ``gaussian`` (``MCPT_FILTER 2``): ``max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)))``,
  ``s = stddev`` (Mitsuba's default filter: 0.5 px), ``r = 4 s``: the Gaussian lowered to reach 0
  at its radius. Its CDF is ``G(x) / G(r)``, ``G(x) = s sqrt(pi/2) (erf(x / (s sqrt 2)) +
  erf(r / (s sqrt 2))) - bias (x + r)``; the shader inverts it by Newton's method from the plain
  Gaussian's inverse (:func:`gauss_constants`): exact to float precision in the bulk.

Cost (user CPU, llvmpipe, Cornell box 128x128 512 spp, render without set-up, alternating runs):
tent 1.01x, Gaussian 1.17x the box; the 100k-triangle bunny: no difference within noise. Path
regeneration starts a sample whenever one lane of a SIMD batch needs one, so the camera code runs
under the mask on most path iterations and only its cheapness matters. (A 128-segment tabulated
inverse CDF with a seven-step binary search cost about as much as the Newton steps: 1.2x.)

Mitsuba's film without ``sample_border`` (the default) keeps only samples ON the film, so a pixel
near the image edge averages the part of its filter that lies inside. mcpt draws the offset from
the filter truncated to the film the same way (per axis: the film is a rectangle and the filter
separable), by mapping u into ``[C(lo), C(hi)]`` of the CDF C, with C at the edge tabulated per
pixel column from the edge (:func:`uniforms`): every sample lands on the film, and the
expectations agree at the border as well.
"""

from __future__ import annotations

import math

import numpy as np

#: The filters mcpt samples (Mitsuba's names) and their MCPT_FILTER values; others are refused.
FILTERS = ("box", "tent", "gaussian")
FILTER_IDS = {name: i for i, name in enumerate(FILTERS)}
#: Mitsuba 3's defaults (src/rfilters/gaussian.cpp, tent.cpp), pixels.
GAUSS_STDDEV = 0.5
GAUSS_RADIUS_STDDEVS = 4.0
TENT_RADIUS = 1.0
#: Pixel columns (rows) from the film's edge whose filter the edge cuts, at most (radius <= 16 px).
EDGES = 16


def radius(kind: str, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS) -> float:
    """The filter's support radius in pixels."""
    if kind == "box":
        return 0.5
    if kind == "tent":
        return float(tent_radius)
    if kind == "gaussian":
        return GAUSS_RADIUS_STDDEVS * float(stddev)
    raise ValueError(f"no pixel filter {kind!r} (known: {FILTERS})")


def evaluate(kind: str, x, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS) -> np.ndarray:
    """The filter's 1-D value at offsets ``x`` (pixels), unnormalised as in Mitsuba."""
    x = np.abs(np.asarray(x, np.float64))
    r = radius(kind, stddev, tent_radius)
    if kind == "box":
        return (x < 0.5).astype(np.float64)
    if kind == "tent":
        return np.maximum(0.0, 1.0 - x / r)
    alpha = -1.0 / (2.0 * stddev * stddev)
    return np.where(x <= r, np.maximum(0.0, np.exp(alpha * x * x) - math.exp(alpha * r * r)), 0.0)


def gauss_constants(stddev: float = GAUSS_STDDEV) -> dict:
    """s = stddev sqrt 2, the bias, erfc(r / s) and the integral over [-r, r] (float64)."""
    r = GAUSS_RADIUS_STDDEVS * stddev
    s = stddev * math.sqrt(2.0)
    bias = math.exp(-r * r / (s * s))
    erfc_r = math.erfc(r / s)
    norm = 2.0 * (0.5 * s * math.sqrt(math.pi) * (1.0 - erfc_r) - bias * r)
    return {"s": s, "bias": bias, "erfc_r": erfc_r, "norm": norm, "r": r}


def cdf(kind: str, x, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS) -> np.ndarray:
    """The filter's CDF at offsets ``x`` (pixels), exact (float64)."""
    x = np.asarray(x, np.float64)
    r = radius(kind, stddev, tent_radius)
    lo = -np.abs(np.clip(x, -r, r))   # the lower half; the upper by symmetry
    if kind == "box":
        low = lo + 0.5
    elif kind == "tent":
        low = (lo + r) ** 2 / (2.0 * r * r)
    else:
        g = gauss_constants(stddev)
        erfc = np.vectorize(math.erfc)
        low = (0.5 * g["s"] * math.sqrt(math.pi) * (erfc(-lo / g["s"]) - g["erfc_r"])
               - g["bias"] * (lo + r)) / g["norm"]
    return np.where(x <= 0.0, low, 1.0 - low)


def uniforms(kind: str, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS) -> dict:
    """The uniforms of glsl/pixel_filter.glsl: the radius, the CDF at the film's edge seen from
    the k-th column (offset -(k + 0.5)) while it is > 0, the Gaussian's constants."""
    r = radius(kind, stddev, tent_radius)
    edge = cdf(kind, -(np.arange(EDGES) + 0.5), stddev, tent_radius)
    out = {"u_filter_radius": r, "u_filter_edge": tuple(float(e) for e in edge),
           "u_filter_edges": int(np.count_nonzero(edge > 0.0))}
    if kind == "gaussian":
        g = gauss_constants(stddev)
        out.update(u_gauss_s=g["s"], u_gauss_bias=g["bias"], u_gauss_erfc_r=g["erfc_r"], u_gauss_norm=g["norm"])
    return out


def sample_reference(kind: str, u, lo=-np.inf, hi=np.inf, stddev: float = GAUSS_STDDEV,
                     tent_radius: float = TENT_RADIUS) -> np.ndarray:
    """Offsets (pixels) for u in [0, 1) restricted to [lo, hi] (the film) by the exact inverse CDF,
    found by bisection in float64: what the shader's ``filter_offset`` approximates (tests)."""
    r = radius(kind, stddev, tent_radius)
    c0, c1 = cdf(kind, np.maximum(lo, -r), stddev, tent_radius), cdf(kind, np.minimum(hi, r), stddev, tent_radius)
    c = c0 + np.asarray(u, np.float64) * (c1 - c0)
    a, b = np.full_like(c, -r), np.full_like(c, r)
    for _ in range(60):
        m = 0.5 * (a + b)
        below = cdf(kind, m, stddev, tent_radius) < c
        a, b = np.where(below, m, a), np.where(below, b, m)
    return 0.5 * (a + b)
