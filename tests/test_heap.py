"""mcpt/heap.py: within setup_heap big arrays reuse freed memory (no new page faults), and leaving
it hands the free memory back to the kernel."""

from __future__ import annotations

import platform
import resource

import numpy as np
import pytest

from mcpt.heap import setup_heap

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc only")


def _faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        return next(int(x.split()[1]) for x in f if x.startswith("VmRSS:")) / 1024


def test_big_arrays_reuse_freed_memory_and_the_rest_is_returned():
    n = 200 * 2**20 // 8  # 200 MB of float64
    with setup_heap():
        first = _faults()
        a = np.ones(n)
        first = _faults() - first
        del a
        again = _faults()
        b = np.ones(n)
        again = _faults() - again
        del b
        held = _rss_mb()
    released = _rss_mb()
    assert first > 50  # the first array's pages were new (2 MB pages at the fewest)
    assert again < first / 10, (first, again)  # the second reused them
    assert held - released > 150, (held, released)  # and leaving gave them back
