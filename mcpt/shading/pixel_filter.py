"""Pixel (reconstruction) filters by filter importance sampling (GLSL side: glsl/pixel_filter.glsl).

mcpt never splats: each camera sample's offset from its pixel's centre is DRAWN from the filter's
own distribution and the sample adds to that one pixel with weight 1 (filter importance sampling,
Ernst et al. 2006, "Filter importance sampling", IEEE RT; pbrt-v4's FilterSampler). The pixel's
mean is then ``integral f(x - c) L(x) dx / integral f`` -- what Mitsuba's splatting film converges
to -- while the image stays a per-pixel sum: deterministic, bit-identical across resume and the
farm. The filters are Mitsuba 3's (src/rfilters/*.cpp), separable ``f(x) f(y)`` in pixels:

* ``box``: 1 inside ``|x| < 0.5`` (radius 0.5): the uniform jitter of before, compiled without
  any of this (``MCPT_FILTER 0``: today's pixels, bit for bit).
* ``tent``: ``max(0, 1 - |x| / r)``, ``r = radius`` (Mitsuba: 1 px).
* ``gaussian``: ``max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)))``, ``s = stddev`` (Mitsuba's
  default filter: 0.5 px), ``r = 4 s``: the Gaussian lowered to reach 0 at its radius.

Both non-box filters are sampled through one table: the filter's value at ``KNOTS`` (at most)
ascending knots over ``[-r, r]``, linear in between, and its normalised running integral. The tent
IS linear between its three knots (-r, 0, r): its inverse CDF is exact (a quadratic per segment).
The Gaussian gets :data:`GAUSS_SEGMENTS` equal segments; linear interpolation departs from it by
at most ``h^2 max|f''| / 8`` (h = 2r / 128): 4.9e-4 of its peak, 3.2e-4 of its integral (see
:func:`interpolation_error`), far below what any image or the chi-square test can see.

Mitsuba's film without ``sample_border`` (the default) keeps only samples ON the film, so a pixel
near the image edge averages the part of its filter that lies inside. mcpt draws the offset from
the filter truncated to the film the same way (per axis: the film is a rectangle and the filter
separable), by mapping u into ``[C(lo), C(hi)]`` of the CDF: every sample still lands in its pixel's
filter support and on the film, and the expectations agree at the border as well.
"""

from __future__ import annotations

import math

import numpy as np

#: The filters mcpt samples (Mitsuba's names); any other ``rfilter`` is refused.
FILTERS = ("box", "tent", "gaussian")
#: Mitsuba 3's defaults (src/rfilters/gaussian.cpp, tent.cpp), pixels.
GAUSS_STDDEV = 0.5
GAUSS_RADIUS_STDDEVS = 4.0
TENT_RADIUS = 1.0
#: Segments of the Gaussian's table; knots in the uniform arrays (fixed size: glsl/pixel_filter.glsl).
GAUSS_SEGMENTS = 128
KNOTS = GAUSS_SEGMENTS + 1
#: What the table pads its unused CDF entries with: above any u, so the search never enters them.
CDF_PAD = 2.0


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
    return np.maximum(0.0, np.exp(alpha * x * x) - math.exp(alpha * r * r))


def knots(kind: str, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS):
    """(x, f): the table's knot positions (pixels, ascending) and the filter's value there."""
    r = radius(kind, stddev, tent_radius)
    n = 2 if kind == "tent" else GAUSS_SEGMENTS
    x = np.linspace(-r, r, n + 1)
    return x, evaluate(kind, x, stddev, tent_radius)


def table(kind: str, stddev: float = GAUSS_STDDEV, tent_radius: float = TENT_RADIUS) -> dict:
    """The uniforms of glsl/pixel_filter.glsl: knots, normalised density at them, CDF, last knot.

    The density is ``f / A`` with ``A`` the integral of the piecewise-linear f (trapezoids, exact
    for it), so the CDF reaches 1 at the last knot; unused entries repeat the last knot with the
    CDF at :data:`CDF_PAD`."""
    x, f = knots(kind, stddev, tent_radius)
    areas = 0.5 * (f[1:] + f[:-1]) * np.diff(x)
    total = float(areas.sum())
    cdf = np.concatenate(([0.0], np.cumsum(areas) / total))
    cdf[-1] = 1.0
    n = len(x)
    pad = KNOTS - n
    return {"u_filter_x": tuple(np.concatenate((x, np.full(pad, x[-1]))).tolist()),
            "u_filter_pdf": tuple(np.concatenate((f / total, np.zeros(pad))).tolist()),
            "u_filter_cdf": tuple(np.concatenate((cdf, np.full(pad, CDF_PAD))).tolist()),
            "u_filter_last": n - 1}


def interpolation_error(stddev: float = GAUSS_STDDEV, fine: int = 200_001) -> tuple[float, float]:
    """(largest gap / peak, L1 gap / integral) between the Gaussian and its linear table."""
    x, f = knots("gaussian", stddev)
    xs = np.linspace(x[0], x[-1], fine)
    exact = evaluate("gaussian", xs, stddev)
    lin = np.interp(xs, x, f)
    gap = np.abs(exact - lin)
    return float(gap.max() / exact.max()), float(gap.sum() / exact.sum())


def sample_reference(kind: str, u, lo=-np.inf, hi=np.inf, stddev: float = GAUSS_STDDEV,
                     tent_radius: float = TENT_RADIUS) -> np.ndarray:
    """numpy twin of the shader's ``filter_offset``: offsets (pixels) for u in [0, 1), restricted
    to [lo, hi] (the film), by the table's inverse CDF (for tests and tools)."""
    t = table(kind, stddev, tent_radius)
    n = t["u_filter_last"] + 1
    x = np.asarray(t["u_filter_x"][:n])
    pdf = np.asarray(t["u_filter_pdf"][:n])
    cdf = np.asarray(t["u_filter_cdf"][:n])

    def cdf_at(v):
        v = np.clip(v, x[0], x[-1])
        i = np.clip(np.searchsorted(x, v, side="right") - 1, 0, n - 2)
        h = x[i + 1] - x[i]
        s = v - x[i]
        return cdf[i] + s * (pdf[i] + 0.5 * (pdf[i + 1] - pdf[i]) * s / h)

    c = cdf_at(np.asarray(lo, np.float64)) + np.asarray(u, np.float64) * (
        cdf_at(np.asarray(hi, np.float64)) - cdf_at(np.asarray(lo, np.float64)))
    i = np.clip(np.searchsorted(cdf, c, side="right") - 1, 0, n - 2)
    h = x[i + 1] - x[i]
    slope = (pdf[i + 1] - pdf[i]) / h
    d = c - cdf[i]
    s = 2.0 * d / np.maximum(pdf[i] + np.sqrt(np.maximum(pdf[i] ** 2 + 2.0 * slope * d, 0.0)), 1e-300)
    return x[i] + np.clip(s, 0.0, h)
