"""Helpers shared by the material and sampling tests (issue #3); no tests of its own.

* :func:`probe` runs tests/glsl/probe_sample.frag: one real GLSL sampling / evaluation routine per item.
* :func:`chi2_test`: the pbrt-v4 / Mitsuba 3 goodness-of-fit test (pool cells expected < 5,
  p-value from the regularised incomplete gamma function; scipy is not a dependency).
* :func:`renderer`: a Renderer for a world and explicit features.
"""

from __future__ import annotations

import math

import numpy as np

from mcpt.gpu.features import Features
from mcpt.gpu.pack import pack

from .probes import run_test_probe

MODE = {"sample": 0, "weight": 1, "eval": 2, "light": 3, "bary": 4, "texture": 5, "normal": 6,
        "eta2": 7, "fresnel_conductor": 8, "cone": 9, "sphere": 10, "eval_t": 11}
TYPE = {"diffuse": 0, "conductor": 1, "dielectric": 2, "plastic": 3, "roughdielectric": 4, "thindielectric": 5,
        "roughplastic": 6, "metalrough": 7}
PROBE_FEATURES = Features.of(bounces=1).everything()


def probe(gl, mode: str, items: np.ndarray, *, tbos=None, features=None, **uniforms) -> np.ndarray:
    """(N, 4) uint32 from tests/glsl/probe_sample.frag in ``mode`` over ``items`` ((N, k<=4)
    floats or uints); ``features``: the program's (default: every code path, PROBE_FEATURES)."""
    items = np.asarray(items)
    n = items.shape[0]
    buf = np.zeros((n, 4), np.uint32)
    if items.dtype == np.float32 or items.dtype == np.float64:
        buf[:, : items.shape[1]] = items.astype(np.float32).view(np.uint32)
    else:
        buf[:, : items.shape[1]] = items.astype(np.uint32)
    unis = {"u_mode": MODE[mode]}
    # Conductor parameters a test does not name: Schlick with lobe scale 1 (today's conductor).
    # Metal-rough: the plain appendix-B dielectric Fresnel (F0 0.04, F90 1) unless a test names one.
    uniforms = {"flags": 0, "scale": (1.0, 1.0, 1.0), "eta": (1.0, 1.0, 1.0), "k": (0.0, 0.0, 0.0),
                "mr_f0": (0.04, 0.04, 0.04), "mr_f90": 1.0, "spec_r": (1.0, 1.0, 1.0), "spec_t": (1.0, 1.0, 1.0),
                **uniforms}  # issue #22: specular factors 1
    for k, v in uniforms.items():
        if k == "type":
            v = TYPE[v]
        if isinstance(v, (list, tuple, np.ndarray)):
            v = tuple(float(x) for x in v)
        unis["u_" + k] = v
    f = PROBE_FEATURES if features is None else features
    return run_test_probe(gl, "probe_sample.frag", buf, n, preamble=f.preamble(),
                          key=("probe_sample", f.key), tbos=tbos, uniforms=unis, width=1024)


def floats(out: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(out).view(np.float32)


def uniform_numbers(n: int, dims: int, seed: int) -> np.ndarray:
    """The renderer's kind of random numbers: float32 k * 2^-24 in [0, 1)."""
    return np.random.default_rng(seed).random((n, dims), dtype=np.float32)


# ----------------------------------------------------------------------------------------------
# chi-square


def gammaincc(a: float, x: float) -> float:
    """Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 6.2: series / Lentz CF)."""
    if x <= 0.0:
        return 1.0
    lg = math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        ap = a
        for _ in range(100000):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * 1e-15:
                break
        return max(0.0, 1.0 - total * math.exp(-x + a * math.log(x) - lg))
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    for i in range(1, 100000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-15:
            break
    return math.exp(-x + a * math.log(x) - lg) * h


def chi2_sf(stat: float, dof: int) -> float:
    return gammaincc(0.5 * dof, 0.5 * stat)


def chi2_test(observed: np.ndarray, expected: np.ndarray, min_expected: float = 5.0):
    """(p-value, statistic, dof). Cells expected < min_expected are pooled into one (pbrt-v4);
    observations where nothing is expected fail outright (p = 0) beyond a 1e-5 share."""
    obs = np.asarray(observed, np.float64).ravel()
    exp = np.asarray(expected, np.float64).ravel()
    n = obs.sum()
    if obs[exp <= 0].sum() > max(1e-5 * n, 0):
        return 0.0, math.inf, 0
    order = np.argsort(exp)
    obs, exp = obs[order], exp[order]
    small = exp < min_expected
    pooled_o, pooled_e = obs[small].sum(), exp[small].sum()
    cells_o, cells_e = list(obs[~small]), list(exp[~small])
    if pooled_e > 0:
        if pooled_e < min_expected and cells_e:  # too small on its own: merge into the next cell
            cells_o[0] += pooled_o
            cells_e[0] += pooled_e
        else:
            cells_o.append(pooled_o)
            cells_e.append(pooled_e)
    o, e = np.asarray(cells_o), np.asarray(cells_e)
    stat = float(np.sum((o - e) ** 2 / e))
    dof = len(o) - 1
    return chi2_sf(stat, dof), stat, dof


def sidak(alpha: float, tests: int) -> float:
    return 1.0 - (1.0 - alpha) ** (1.0 / tests)


# ----------------------------------------------------------------------------------------------
# spherical histograms: (cos theta, phi) is area-preserving, so a cell's probability is its
# mean density times d(cos theta) d(phi).


def sphere_grid(n_theta: int, n_phi: int, ires: int):
    """Midpoints of ires x ires sub-cells of every cell, as unit vectors (n_theta*n_phi*ires^2, 3)."""
    ct = -1.0 + (np.arange(n_theta * ires) + 0.5) * (2.0 / (n_theta * ires))
    ph = -np.pi + (np.arange(n_phi * ires) + 0.5) * (2.0 * np.pi / (n_phi * ires))
    C, P = np.meshgrid(ct, ph, indexing="ij")
    s = np.sqrt(np.maximum(0.0, 1.0 - C**2))
    return np.stack([s * np.cos(P), s * np.sin(P), C], axis=-1).reshape(-1, 3)


def cell_probabilities(pdf_values: np.ndarray, n_theta: int, n_phi: int, ires: int) -> np.ndarray:
    p = np.asarray(pdf_values, np.float64).reshape(n_theta, ires, n_phi, ires).mean(axis=(1, 3))
    return p * (2.0 / n_theta) * (2.0 * np.pi / n_phi)


def sphere_histogram(w: np.ndarray, n_theta: int, n_phi: int) -> np.ndarray:
    ct = np.clip(w[:, 2], -1.0, 1.0)
    ph = np.arctan2(w[:, 1], w[:, 0])
    h, _, _ = np.histogram2d(ct, ph, bins=[n_theta, n_phi], range=[[-1.0, 1.0], [-np.pi, np.pi]])
    return h


# ----------------------------------------------------------------------------------------------
# rendering


def renderer(gl, world, features):
    """A Renderer for ``world`` with ``features`` (which may differ from the world's own)."""
    from mcpt.gpu.render import Renderer

    return Renderer(gl, features, pack(world, features))
