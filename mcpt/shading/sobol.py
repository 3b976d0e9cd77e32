"""Padded, Owen-scrambled Sobol' numbers: the numpy twin of glsl/sobol.glsl (``--sampler sobol``).

What the shader computes, bit for bit, so tests can check the GPU against this file and the
statistics (uniformity, (0,2)-net stratification) on this file:

* Every path dimension ``dim`` of every pixel is its own padded 1D or 2D sample (pbrt-v4's
  ``PaddedSobolSampler``; dimension numbering: mcpt/shading/sampler.py). Its seed is a hash of
  (``--seed``, pixel, dim), so no table is uploaded at all, per pass or once: a pass only sets
  one uniform, the sample index (= the pass index).
* The sample index is shuffled per (pixel, dim) by a nested uniform (Owen) scramble of its
  bits (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4), sec. 5 "shuffled
  scrambled Sobol'"): this decorrelates dimensions from one another (padding) while the first
  2^m indices still map onto a set of Sobol' points that is a (0, m, 2)-net, because an index's
  bits >= m only move a point inside its 2^-m stratum.
* The 2D point is Sobol' dimensions 0 and 1 (a (0, 2)-sequence); dimension 0 is the bit
  reversal of the index, dimension 1's generator matrix is Pascal's triangle mod 2, i.e. bit r
  of the result (from the top) is the XOR of the index bits c with r a bit-subset of c: a
  superset transform in five shift/mask steps instead of a 32-step loop.
* Each coordinate is then Owen-scrambled with its own seed by Burley's Laine-Karras style hash
  (bits only affect higher bits in the reversed domain = a nested uniform scramble), which keeps
  the net property and makes every point uniform on its own (unbiased).
* 24 bits become a float in [0, 1) exactly ((v >> 8) * 2^-24), never 1.0.

Cost on llvmpipe: a few dozen integer vector instructions per number, against a per-lane
``texelFetch`` per number for the ``independent`` sampler (which dominates; glsl/sampler.glsl).
"""

from __future__ import annotations

import numpy as np

U32 = np.uint32


def _u(x) -> np.ndarray:
    return np.asarray(x, dtype=U32)


def seed32(seed: int) -> int:
    """The 32-bit key the shader hashes, from ``--seed`` (any int >= 0, as numpy's SeedSequence)."""
    return int(np.random.SeedSequence([int(seed), 0x50B01]).generate_state(1, np.uint32)[0])


def hash32(x) -> np.ndarray:
    """A 32-bit integer hash with good avalanche (C. Wellons, "lowbias32", 2018)."""
    x = _u(x).copy()
    with np.errstate(over="ignore"):
        x ^= x >> U32(16)
        x *= U32(0x7FEB352D)
        x ^= x >> U32(15)
        x *= U32(0x846CA68B)
        x ^= x >> U32(16)
    return x


def reverse_bits(x) -> np.ndarray:
    x = _u(x).copy()
    x = ((x >> U32(1)) & U32(0x55555555)) | ((x & U32(0x55555555)) << U32(1))
    x = ((x >> U32(2)) & U32(0x33333333)) | ((x & U32(0x33333333)) << U32(2))
    x = ((x >> U32(4)) & U32(0x0F0F0F0F)) | ((x & U32(0x0F0F0F0F)) << U32(4))
    x = ((x >> U32(8)) & U32(0x00FF00FF)) | ((x & U32(0x00FF00FF)) << U32(8))
    return (x >> U32(16)) | (x << U32(16))


def laine_karras(x, seed) -> np.ndarray:
    """A hash in which each bit depends only on itself and lower bits (so, on reversed bits, a
    nested uniform scramble). Burley 2020's listing 2 left the 4 samples of a pixel visibly
    correlated below their strata (chi-square p ~ 1e-5 pooled over 4096 pixels); this is N.
    Vegdahl's improved version ("Building a Better LK Hash", 2021), as pbrt-v4's FastOwenScrambler."""
    s = _u(seed)
    with np.errstate(over="ignore"):
        x = _u(x).copy()
        x ^= x * U32(0x3D20ADEA)
        x = x + s
        x = x * ((s >> U32(16)) | U32(1))
        x ^= x * U32(0x05526C56)
        x ^= x * U32(0x53A22864)
    return x


def pascal(i) -> np.ndarray:
    """Sobol' dimension 1 of index ``i``, bit-reversed: bit r = XOR of bits c of i with r within c."""
    u = _u(i).copy()
    u ^= (u >> U32(1)) & U32(0x55555555)
    u ^= (u >> U32(2)) & U32(0x33333333)
    u ^= (u >> U32(4)) & U32(0x0F0F0F0F)
    u ^= (u >> U32(8)) & U32(0x00FF00FF)
    u ^= (u >> U32(16)) & U32(0x0000FFFF)
    return u


def pixel_seed(seed: int, pixel) -> np.ndarray:
    """Per-pixel key; ``pixel`` = row * width + column over the whole image (rows from the top)."""
    return hash32(_u(seed32(seed)) ^ hash32(pixel))


def dim_seeds(pseed, dim) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(index shuffle, x scramble, y scramble) seeds of one dimension of one pixel."""
    with np.errstate(over="ignore"):
        s = hash32(_u(pseed) ^ hash32(dim))
        return s, hash32(s + U32(1)), hash32(s + U32(2))


def to_float(v) -> np.ndarray:
    return (_u(v) >> U32(8)).astype(np.float32) * np.float32(2.0**-24)


def sample_bits(seed: int, pixel, dim, index) -> tuple[np.ndarray, np.ndarray]:
    """The scrambled 32-bit (x, y) of sample ``index`` of dimension ``dim`` of ``pixel`` (broadcast)."""
    s, sx, sy = dim_seeds(pixel_seed(seed, pixel), dim)
    shuffled = reverse_bits(laine_karras(reverse_bits(index), s))
    return reverse_bits(laine_karras(shuffled, sx)), reverse_bits(laine_karras(pascal(shuffled), sy))


def sample_2d(seed: int, pixel, dim, index) -> np.ndarray:
    """What ``rand2_at(dim)`` returns in pass ``index``: shape (..., 2) float32 in [0, 1)."""
    x, y = sample_bits(seed, pixel, dim, index)
    return np.stack([to_float(x), to_float(y)], axis=-1)
