"""The sobol sampler (mcpt/shading/sobol.py, glsl/sobol.glsl): GPU = numpy bit for bit, then the math."""

import numpy as np
import pytest

from mcpt.gpu.context import shared_context
from mcpt.shading import sobol

from .probes import run_test_probe
from .test_materials_util import chi2_test

U32 = np.uint32


def sobol_from_direction_numbers(index, dim: int) -> np.ndarray:
    """Plain Sobol' dimension 0 or 1 from its direction numbers (Joe & Kuo: dim 1 has m_1 = 1)."""
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


def test_gpu_matches_numpy_bit_for_bit():
    rng = np.random.default_rng(1)
    n = 4096
    probe = np.zeros((n, 4), U32)
    probe[:, 0] = rng.integers(0, 1 << 20, n)        # pixel
    probe[:, 1] = rng.integers(0, 600_002, n)        # dim (100 000 bounces)
    probe[:, 2] = rng.integers(0, 1 << 20, n)        # sample index
    probe[:8, 2] = np.arange(8)
    seed = 12345
    gl = shared_context()
    out = run_test_probe(gl, "probe_sobol.frag", probe, n, key="sobol",
                         uniforms={"u_sobol_seed": sobol.seed32(seed)})
    got = out[:, :3].view(np.float32)
    want = sobol.sample_2d(seed, probe[:, 0], probe[:, 1], probe[:, 2])
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
