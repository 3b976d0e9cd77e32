"""The sobol sampler (mcpt/shading/sobol.py, glsl/sobol.glsl): GPU = numpy bit for bit, then the math."""

import numpy as np
import pytest

from mcpt.gpu.context import shared_context
from mcpt.shading import sobol
from mcpt.shading.sampler import JOINT_DIMS, layout_defines

from .probes import run_test_probe
from .test_materials_util import chi2_test

U32 = np.uint32
_PREAMBLE = "".join(f"#define {k} {v}\n" for k, v in layout_defines().items())


# Joe & Kuo's new-joe-kuo-6.21201, d = 3..6, as printed there: (s, a, m_1..m_s).
_JOE_KUO_TABLE = ((2, 1, (1, 3)), (3, 1, (1, 3, 1)), (3, 2, (1, 1, 1)), (4, 1, (1, 1, 3, 3)))


def _joe_kuo_vectors(s: int, a: int, m: tuple) -> list:
    """Direction numbers v_k = m_k 2^(32-k) by Joe & Kuo's own recurrence on v (their eq. for
    v_k, with the polynomial's inner coefficients a), independent of sobol.direction_numbers."""
    v = [U32(mk << (31 - k)) for k, mk in enumerate(m)]
    for k in range(s, 32):
        x = v[k - s] ^ (v[k - s] >> U32(s))
        for j in range(1, s):
            if (a >> (s - 1 - j)) & 1:
                x ^= v[k - j]
        v.append(U32(x))
    return v


def sobol_from_direction_numbers(index, dim: int) -> np.ndarray:
    """Plain Sobol' dimension ``dim`` (0-5) from its direction numbers (Joe & Kuo: dim 1 has m_1 = 1)."""
    if dim >= 2:
        v = _joe_kuo_vectors(*_JOE_KUO_TABLE[dim - 2])
    else:
        v = [U32(1 << 31)]
        for _ in range(31):
            v.append(v[-1] ^ (v[-1] >> U32(1)) if dim == 1 else v[-1] >> U32(1))
    i = np.asarray(index, U32)
    out = np.zeros_like(i)
    for c in range(32):
        out ^= np.where((i >> U32(c)) & U32(1), v[c], U32(0)).astype(U32)
    return out


def test_pascal_transform_is_sobol_dimension_1():
    rng = np.random.default_rng(0)
    idx = np.concatenate([np.arange(4096, dtype=U32), rng.integers(0, 2**32, 4096, dtype=U32)])
    assert np.array_equal(sobol.reverse_bits(idx), sobol_from_direction_numbers(idx, 0))
    assert np.array_equal(sobol.reverse_bits(sobol.pascal(idx)), sobol_from_direction_numbers(idx, 1))


@pytest.mark.parametrize("joint", [True, False])
def test_gpu_matches_numpy_bit_for_bit(joint):
    rng = np.random.default_rng(1)
    n = 4096
    probe = np.zeros((n, 4), U32)
    probe[:, 0] = rng.integers(0, 1 << 20, n)        # pixel
    probe[:, 1] = rng.integers(0, 600_002, n)        # dim (100 000 bounces)
    probe[:, 2] = rng.integers(0, 1 << 20, n)        # sample index
    probe[:8, 2] = np.arange(8)
    # the joint point's dims, their neighbours, and indices past its 16 shuffled bits
    probe[8:1032, 1] = np.tile(np.arange(3, 15), 86)[:1024]
    probe[8:264, 2] = rng.integers(0, 1 << 16, 256)
    seed = 12345
    gl = shared_context()
    out = run_test_probe(gl, "probe_sobol.frag", probe, n, key=("sobol", joint),
                         preamble=_PREAMBLE + f"#define MCPT_SOBOL_JOINT {int(joint)}\n",
                         uniforms={"u_sobol_seed": sobol.seed32(seed)})
    got = out[:, :3].view(np.float32)
    want = sobol.sample_2d(seed, probe[:, 0], probe[:, 1], probe[:, 2], joint=joint)
    assert np.array_equal(got[:, :2], want)
    assert np.array_equal(got[:, 2], want[:, 0])


@pytest.mark.parametrize("m", [0, 1, 3, 6, 8])
def test_first_2_to_the_m_samples_form_a_0_m_2_net(m):
    """Every elementary interval of area 2^-m (all 2^a x 2^(m-a) shapes) holds exactly one point."""
    n = 1 << m
    idx = np.arange(n, dtype=U32)
    for pixel, dim in [(0, 0), (7, 3), (65535, 1), (123, 599_999)]:
        x, y = sobol.sample_bits(99, pixel, dim, idx)
        for a in range(m + 1):
            cell = (x >> U32(32 - a) if a else 0 * x).astype(np.int64) * (1 << (m - a)) + \
                   (y >> U32(32 - (m - a)) if m - a else 0 * y).astype(np.int64)
            assert np.array_equal(np.sort(cell), np.arange(n)), (pixel, dim, a)


def test_each_dimension_is_uniform_over_pixels_and_passes():
    """Chi-square on 64 bins for several dimensions, pooled over 4096 pixels x 4 passes."""
    pix = np.arange(4096, dtype=U32)[:, None]
    idx = np.arange(4, dtype=U32)[None, :]
    pvals = []
    for dim in [0, 1, 2, 5, 50, 6001]:
        u = sobol.sample_2d(7, pix, dim, idx).reshape(-1, 2)
        assert u.min() >= 0.0 and u.max() < 1.0
        for c in range(2):
            counts = np.bincount((u[:, c] * 64).astype(int), minlength=64)
            pvals.append(chi2_test(counts, np.full(64, counts.sum() / 64))[0])
    # 12 tests: all above 1e-4 holds with probability > 0.998 for a uniform generator.
    assert min(pvals) > 1e-4, pvals


def test_padded_dimensions_are_independent_of_one_another():
    """Pairs (dim a, dim b) of one pixel and pass: chi-square on an 8 x 8 grid (padding works)."""
    pix = np.arange(16384, dtype=U32)[:, None]
    idx = np.arange(8, dtype=U32)[None, :]
    pvals = []
    for a, b in [(0, 2), (2, 3), (3, 5), (8, 14)]:
        ua = sobol.sample_2d(3, pix, a, idx).reshape(-1, 2)[:, 0]
        ub = sobol.sample_2d(3, pix, b, idx).reshape(-1, 2)[:, 0]
        h = np.histogram2d(ua, ub, bins=8, range=[[0, 1], [0, 1]])[0].ravel()
        pvals.append(chi2_test(h, np.full(64, h.sum() / 64))[0])
    assert min(pvals) > 1e-4, pvals


def test_seeds_pixels_and_passes_give_different_numbers():
    pix = np.arange(1024, dtype=U32)
    a = sobol.sample_2d(1, pix, 4, 0)
    assert np.array_equal(a, sobol.sample_2d(1, pix, 4, 0))
    assert np.mean(a == sobol.sample_2d(2, pix, 4, 0)) < 0.01
    assert np.mean(a == sobol.sample_2d(1, pix, 4, 1)) < 0.01
    assert np.mean(a == sobol.sample_2d(1, pix, 5, 0)) < 0.01
    assert len(np.unique(a[:, 0])) > 1000 * 0.95


def test_joint_columns_are_sobol_dimensions_2_to_5():
    """The shader's columns (sobol.JOINT_COLUMNS) give Joe & Kuo's Sobol' dimensions 2-5 for every
    16-bit index (reversed domain: the matrix applied to i, bit-reversed)."""
    idx = np.arange(1 << 16, dtype=U32)
    for t, cols in enumerate(sobol.JOINT_COLUMNS):
        assert np.array_equal(sobol.reverse_bits(sobol.matrix(idx, cols)), sobol_from_direction_numbers(idx, t + 2))
    assert np.array_equal(sobol.reverse_bits(idx), sobol_from_direction_numbers(idx, 0))


def _interval_counts(bits: np.ndarray, split: tuple) -> np.ndarray:
    """Sorted point counts of the elementary intervals with ``split[c]`` leading bits in coordinate c."""
    cell = np.zeros(bits.shape[0], np.int64)
    for c, b in enumerate(split):
        if b:
            cell = (cell << b) | (bits[:, c] >> U32(32 - b)).astype(np.int64)
    return np.sort(np.bincount(cell, minlength=1 << sum(split)))


@pytest.mark.parametrize("m", [4, 6, 8])
def test_joint_point_keeps_the_sobol_nets_strata(m):
    """The first 2^m samples of a pixel's joint point fill every elementary interval of its 2D and
    4D projections exactly as the unscrambled Sobol' points 0..2^m - 1 do (an Owen scramble and a
    shuffle within an aligned block of 2^m indices only permute intervals): the bounces' directions
    are stratified together, which padded pairs are not."""
    n = 1 << m
    idx = np.arange(n, dtype=U32)
    plain = np.stack([sobol_from_direction_numbers(idx, d) for d in range(6)], axis=-1)
    splits = [(2, 6), (4, 4)] if m == 8 else [(m // 2, m - m // 2)]
    for pixel in (0, 77, 4095):
        got = sobol.joint_bits(5, pixel, idx)
        for cs in [(0, 1), (0, 2), (1, 4), (2, 3), (4, 5), (0, 1, 4, 5), (0, 2, 3, 4)]:
            for split in splits if len(cs) == 2 else [(m // 4,) * 4, (m // 4 + 1, m // 4 - 1, m // 4, m // 4)]:
                assert np.array_equal(_interval_counts(got[:, cs], split),
                                      _interval_counts(plain[:, cs], split)), (pixel, cs, split)
    # padded pairs of those dims would not: (x of bounce 1, x of bounce 2) at 2^m points
    pad = np.stack([sobol.sample_bits(5, 0, d, idx)[0] for d in (JOINT_DIMS[0] + 100, JOINT_DIMS[2] + 100)], -1)
    assert not np.array_equal(_interval_counts(pad, (m // 2, m - m // 2)), np.ones(n, np.int64))


def test_joint_point_is_uniform_and_independent_of_padded_dims():
    """Chi-square: each joint coordinate on 64 bins, and (joint, padded) pairs on an 8 x 8 grid,
    pooled over 4096 pixels x 8 passes, also past the 16 shuffled index bits."""
    pix = np.arange(4096, dtype=U32)[:, None]
    pvals = []
    for idx in (np.arange(8, dtype=U32), np.arange(8, dtype=U32) + U32(3 << 16)):
        u = sobol.sample_2d(11, pix, np.array(JOINT_DIMS, U32)[:, None, None], idx[None, :]).reshape(3, -1, 2)
        for t in range(3):
            for c in range(2):
                counts = np.bincount((u[t, :, c] * 64).astype(int), minlength=64)
                pvals.append(chi2_test(counts, np.full(64, counts.sum() / 64))[0])
        for d in (JOINT_DIMS[0] + 1, JOINT_DIMS[0] + 2, 0):  # the 1D after a pair, roulette, camera
            v = sobol.sample_2d(11, pix, d, idx[None, :]).reshape(-1, 2)[:, 0]
            h = np.histogram2d(u[0, :, 0], v, bins=8, range=[[0, 1], [0, 1]])[0].ravel()
            pvals.append(chi2_test(h, np.full(64, h.sum() / 64))[0])
    # 42 tests: all above 1e-5 holds with probability > 0.9995 for uniform, independent numbers.
    assert min(pvals) > 1e-5, pvals


def test_joint_point_past_2_to_the_16_samples_is_not_a_repeat():
    """Sample 2^16 + i and sample i share their 16 shuffled bits but not their scrambles."""
    idx = np.arange(256, dtype=U32)
    a, b = sobol.joint_bits(2, 9, idx), sobol.joint_bits(2, 9, idx + U32(1 << 16))
    assert np.mean(a == b) < 0.01
    assert np.array_equal(_interval_counts(b[:, :2], (4, 4)), np.ones(256, np.int64))
