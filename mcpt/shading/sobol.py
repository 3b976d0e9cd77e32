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
* Except the three 2D samples of ``sampler.JOINT_DIMS`` (the first hit's BSDF direction, the
  second hit's light point and BSDF direction): those six numbers are one point of Sobol'
  dimensions 0-5 (Joe & Kuo's direction numbers), with one index shuffle per pixel shared by all
  six and an Owen scramble per coordinate: the first 2^m samples of a pixel are a scrambled
  (t, m, 6)-net, so the two bounces' directions are stratified jointly, not paired at random.
  Padding them had left mcpt's error per sample level with Mitsuba 3's ``multijitter``; joining
  them cut relMSE at 256 spp by 11 % (Cornell box) and 14 % (100k sphere), bench/sampler-quality.md
  (issue #23). Every number is still uniform on its own and the joint point uniform in [0, 1)^6
  (Owen 1995), so nothing is biased. The shuffle keeps 16 index bits (2^16 samples a pixel);
  each further 2^16 samples are a new scramble (the bits above 16 seed it). Paths of one bounce
  never reach the second hit: their programs leave the joint point out (``sampler.joint_used``)
  and draw the same numbers as before it.

Cost on llvmpipe: a few dozen integer vector instructions per number, against a per-lane
``texelFetch`` per number for the ``independent`` sampler (which dominates; glsl/sampler.glsl).
"""

from __future__ import annotations

import numpy as np

from .sampler import JOINT_DIMS

U32 = np.uint32

#: Sobol' dimensions 2-5: primitive polynomial (with both end terms) and initial direction
#: numbers m_1..m_s (S. Joe and F. Y. Kuo 2008, new-joe-kuo-6.21201, its lines d = 3..6).
JOE_KUO = ((0b111, (1, 3)), (0b1011, (1, 3, 1)), (0b1101, (1, 1, 1)), (0b10011, (1, 1, 3, 3)))
JOINT_BITS = 16            # index bits the joint point's generator matrices read
JOINT_SALT = 0x6A09E667    # the joint index shuffle's key is hash(pixel key ^ this)


def direction_numbers(poly: int, m: tuple[int, ...], count: int = JOINT_BITS) -> list[int]:
    """m_1..m_count of one Sobol' dimension (Bratley & Fox 1988's recurrence; column k of the
    generator matrix is m_(k+1) / 2^(k+1))."""
    s = poly.bit_length() - 1
    out = list(m)
    for k in range(s, count):
        new = out[k - s] ^ (out[k - s] << s)
        for j in range(1, s):
            if (poly >> (s - j)) & 1:
                new ^= out[k - j] << j
        out.append(new)
    return out[:count]


def _reversed_columns(poly: int, m: tuple[int, ...]) -> tuple[int, ...]:
    """The generator matrix's columns in the bit-reversed domain the shader works in: column k
    (index bit k) is m_(k+1) written backwards in k + 1 bits."""
    return tuple(int(f"{mk:0{k + 1}b}"[::-1], 2) for k, mk in enumerate(direction_numbers(poly, m)))


#: (4, 16): Sobol' dimensions 2-5 of the joint point; glsl/sobol.glsl writes the same words.
JOINT_COLUMNS = tuple(_reversed_columns(p, m) for p, m in JOE_KUO)


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


def matrix(i, columns) -> np.ndarray:
    """Bit-reversed Sobol' coordinate of index ``i``: the XOR of the columns of its set bits."""
    i = _u(i)
    out = np.zeros_like(i)
    for k, c in enumerate(columns):
        out ^= np.where((i >> U32(k)) & U32(1), U32(c), U32(0)).astype(U32)
    return out


def joint_bits(seed: int, pixel, index) -> np.ndarray:
    """The scrambled 32-bit coordinates (..., 6) of the joint point (JOINT_DIMS' three pairs in
    order) of sample ``index`` of ``pixel`` (broadcast)."""
    idx = _u(index)
    with np.errstate(over="ignore"):
        key = hash32(pixel_seed(seed, pixel) ^ U32(JOINT_SALT))
        low = reverse_bits(laine_karras(reverse_bits(idx), key)) & U32(0xFFFF)
        epoch = hash32(key ^ (idx >> U32(JOINT_BITS)))
        coords = [low, pascal(low)] + [matrix(low, c) for c in JOINT_COLUMNS]
        return np.stack([reverse_bits(laine_karras(v, hash32(epoch + U32(t + 1))))
                         for t, v in enumerate(coords)], axis=-1)


def sample_2d(seed: int, pixel, dim, index, joint: bool = True) -> np.ndarray:
    """What ``rand2_at(dim)`` returns in pass ``index``: shape (..., 2) float32 in [0, 1); its x is
    what ``rand_at(dim)`` returns. ``joint``: the program has the joint point (MCPT_SOBOL_JOINT,
    ``sampler.joint_used``); without it every dim is padded."""
    x, y = sample_bits(seed, pixel, dim, index)
    out = np.stack([to_float(x), to_float(y)], axis=-1)
    if not joint:
        return out
    joint_at = [np.broadcast_to(_u(dim) == U32(d), out.shape[:-1]) for d in JOINT_DIMS]
    if not any(at.any() for at in joint_at):
        return out
    point = np.broadcast_to(to_float(joint_bits(seed, pixel, index)), out.shape[:-1] + (6,))
    for t, at in enumerate(joint_at):
        out[at] = point[at][:, 2 * t:2 * t + 2]
    return out
