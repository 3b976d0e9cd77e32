"""mcpt/shapes/rows.py: whole-row gathers give numpy's fancy indexing's result, bit for bit."""

import numpy as np
import pytest

from mcpt.shapes.rows import take_rows


@pytest.mark.parametrize("shape, dtype", [((50, 3), np.float32), ((40, 3, 3), np.float32), ((30, 2), np.int64),
                                          ((20, 3), np.float64), ((10,), np.int32), ((25, 3, 4), np.uint32)])
def test_take_rows_equals_fancy_indexing(shape, dtype):
    rng = np.random.default_rng(len(shape) * 7 + shape[0])
    a = (rng.standard_normal(shape) * 1000).astype(dtype)
    for index in (rng.integers(-shape[0], shape[0], 17), rng.integers(0, shape[0], (6, 3)), np.zeros(0, np.int64)):
        got = take_rows(a, index)
        assert got.dtype == a.dtype and got.shape == a[index].shape
        assert np.array_equal(got.view(np.uint8), a[index].view(np.uint8))


def test_take_rows_moves_bits_not_values():
    # Signalling NaNs and -0.0 survive: rows are copied, never converted.
    bits = np.array([[0x7F800001, 0x80000000, 0x3F800000], [0xFFC00001, 0, 0x00000001]], np.uint32)
    a = bits.view(np.float32)
    assert np.array_equal(take_rows(a, np.array([1, 0, 1])).view(np.uint32), bits[[1, 0, 1]])
    # A non-contiguous view reads as its values.
    b = np.arange(24, dtype=np.float32).reshape(4, 6)[:, ::2]
    assert np.array_equal(take_rows(b, np.array([3, 1])), b[[3, 1]])


def test_take_rows_refuses_what_fancy_indexing_refuses():
    with pytest.raises(IndexError):
        take_rows(np.zeros((3, 2)), np.array([3]))


def test_put_rows_equals_fancy_assignment():
    from mcpt.shapes.rows import put_rows

    rng = np.random.default_rng(5)
    for shape in ((40, 4), (30, 8), (12, 3, 3)):
        rows = rng.integers(0, 2**32, (10,) + shape[1:], dtype=np.uint32)
        index = rng.permutation(shape[0])[:10]
        got, want = np.zeros(shape, np.uint32), np.zeros(shape, np.uint32)
        put_rows(got, index, rows)
        want[index] = rows
        assert np.array_equal(got, want)
    with pytest.raises(ValueError):
        put_rows(np.zeros((4, 6), np.uint32)[:, ::2], np.array([0]), np.zeros((1, 3), np.uint32))


def test_take_rows_into_out_equals_fancy_indexing():
    """The ``out`` form: the same rows, into the given array (a slice of a larger one too);
    negative indices, an index out of range and a wrong ``out`` behave as without it."""
    rng = np.random.default_rng(9)
    a = rng.normal(size=(50, 3)).astype(np.float32)
    index = rng.integers(-50, 50, (40, 3))
    big = np.zeros((60, 3, 3), np.float32)
    got = take_rows(a, index, out=big[10:50])
    assert got.base is not None and np.array_equal(big[10:50], a[index])
    assert not big[:10].any() and not big[50:].any()
    with pytest.raises(IndexError):
        take_rows(a, np.array([[50, 0, 1]]), out=np.empty((1, 3, 3), np.float32))
    with pytest.raises(ValueError):
        take_rows(a, index, out=np.empty((40, 3, 3), np.float64))
    empty = np.empty((0, 3, 3), np.float32)
    assert take_rows(a, np.zeros((0, 3), np.int64), out=empty) is empty
