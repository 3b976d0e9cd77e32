"""How much host memory a render takes, measured, and how much this machine has.

Peak resident memory of ``mcpt render`` on llvmpipe (``/usr/bin/time -f %M``, Cornell box, 1 spp;
issue #24, the former estimate counted only the float64 sums and was 2.3-2.8x low):

    pixels    1 target (beauty)    4 targets (--aov albedo,normal,depth,variance)
    256^2       168 MB                 214 MB
    1024^2      279 MB                 600 MB
    2048^2      623 MB                1930 MB

and of a scene's triangles (issue #24; 8x8 pixels, 1 spp, the world cache off):

    triangles            spheres (XML, smooth normals)   the same textured    a grid OBJ (flat)
    98 280 / 100 352           201 MB                       231 MB              204 MB
    1 015 560 / 1 002 528      750 MB                       791 MB              558 MB
    3 996 720 / 4 004 450     2257 MB                         -                1666 MB

that is 540-625 bytes a triangle for spheres (their corner normals), 383 for a flat mesh, while
the world is built (mesh parts in float64, their concatenation, the BVH build) and packed.

The image's share is 112 bytes a pixel for one target and 433 for four: ~107 bytes a pixel per
target (the float64 sums and float32 read-backs, the GL driver's RGBA32F targets and path-state images, the
image and its layers as they are written), plus ~165 MB of interpreter, Mesa and scene.
"""

from __future__ import annotations

import os

#: Measured above, rounded up: bytes per pixel per accumulation target, and the fixed part.
BYTES_PER_PIXEL_TARGET = 120
BASE_BYTES = 176 * 2**20
#: Measured above, rounded up: peak bytes per triangle of the scene (mcpt/gpu/scene_size.py).
BYTES_PER_TRIANGLE = 640


def host_bytes(width: int, height: int, targets: int) -> int:
    """Peak host memory of a render of ``width`` x ``height`` with ``targets`` targets."""
    return BASE_BYTES + width * height * targets * BYTES_PER_PIXEL_TARGET


def available_bytes() -> int | None:
    """Memory this process may still use: MemAvailable, or the cgroup's limit where lower
    (a container, a batch job); None where neither can be read."""
    found = []
    try:
        with open("/proc/meminfo") as f:
            found += [int(ln.split()[1]) * 1024 for ln in f if ln.startswith("MemAvailable:")]
    except OSError:
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            text = f.read().strip()
        if text.isdigit():
            found.append(int(text))
    except OSError:
        pass
    if not found:
        try:
            found.append(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
        except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
            return None
    return min(found)
