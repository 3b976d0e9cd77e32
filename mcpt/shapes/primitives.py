"""Analytic shapes tessellated into triangle meshes: rectangle, cube, disk, sphere, cylinder.

Each producer is a pure function returning :class:`Primitive` arrays in the shape's OWN frame,
which is Mitsuba 3's (the object-to-world transform is applied by the caller):

* ``rectangle``: the square [-1, 1]^2 at z = 0, facing +z; uv = ((x+1)/2, (y+1)/2).
* ``cube``: [-1, 1]^3, faces outward, 4 vertices per face (flat normals), uv [0, 1]^2 per face.
* ``disk``: the unit disk at z = 0, facing +z; uv = (r, phi / 2 pi).
* ``sphere``: the unit sphere, facing outward; uv = (phi / 2 pi, theta / pi).
* ``cylinder``: the open unit cylinder x^2 + y^2 = 1, 0 <= z <= 1 (no caps, as Mitsuba's),
  facing outward; uv = (phi / 2 pi, z).

UVs follow Mitsuba (v = 0 at the image's TOP row), and mcpt's textures put v = 0 at the bottom,
so every ``uvs`` array here holds ``(u, 1 - v)``.

How fine: curved outlines are polygons INSCRIBED in the true curve, with ``segments(tolerance)``
edges per full turn, so that no point of the mesh lies farther than ``tolerance`` x radius from the
true surface (the sagitta of one edge: r (1 - cos(pi / n)) <= tolerance r). The default
:data:`TOLERANCE` = 3e-4 gives 129 segments per turn (a sphere, whose cells are two-dimensional: 182
segments and 32 760 triangles): at 1000 pixels across, the silhouette is off by at most 0.15 pixel,
and the tessellated area (hence an emitting sphere's power) is short of the true one by less than 2
x tolerance = 0.06 % (disk: 4/3, sphere: 5/3 of it) -- below the noise of any render we compare.
Normals are the analytic (smooth) ones, which Mitsuba's analytic shapes shade with; the mesh normal
decides only which side is the front.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Largest distance from the true surface, relative to the radius (see the module doc).
TOLERANCE = 3e-4
#: Fewest and most segments per full turn (the second bounds memory whatever tolerance is asked).
MIN_SEGMENTS, MAX_SEGMENTS = 8, 4096
KINDS = ("rectangle", "cube", "disk", "sphere", "cylinder")


@dataclass(frozen=True)
class Primitive:
    """A tessellated shape: positions (N, 3) float64, faces (M, 3) int64 counter-clockwise seen
    from the front, unit normals (N, 3) float64, uvs (N, 2) float64 (mcpt's v-up convention)."""

    positions: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray


def segments(tolerance: float = TOLERANCE) -> int:
    """Edges per full turn so that the sagitta 1 - cos(pi / n) stays <= ``tolerance`` (radius 1)."""
    if not 0.0 < tolerance < 1.0:
        raise ValueError(f"tolerance {tolerance} must lie in (0, 1)")
    n = math.ceil(math.pi / math.acos(1.0 - tolerance))
    return int(min(max(n, MIN_SEGMENTS), MAX_SEGMENTS))


def _grid(nu: int, nv: int) -> np.ndarray:
    """Two triangles per cell of a (nu+1) x (nv+1) vertex grid (index = i * (nv+1) + j),
    counter-clockwise when u runs right and v runs up."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * (nv + 1) + j).ravel()
    b, c, d = a + (nv + 1), a + (nv + 2), a + 1
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)


def rectangle() -> Primitive:
    p = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    uv = (p[:, :2] + 1.0) / 2.0
    return Primitive(p, np.array([[0, 1, 2], [0, 2, 3]], np.int64),
                     np.tile([0.0, 0.0, 1.0], (4, 1)), np.stack([uv[:, 0], 1.0 - uv[:, 1]], 1))


def cube() -> Primitive:
    """Six faces of [-1, 1]^3, each the rectangle turned to face outward."""
    quad = rectangle()
    pos, faces, nrm, uvs = [], [], [], []
    # (axis the face looks along, sign): a rotation taking +z there.
    frames = [np.eye(3), np.diag([1.0, -1.0, -1.0]),
              np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float), np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]], float),
              np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float), np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float)]
    for k, r in enumerate(frames):
        pos.append((quad.positions + [0.0, 0.0, 1.0]) @ r.T)
        nrm.append(quad.normals @ r.T)
        faces.append(quad.faces + 4 * k)
        uvs.append(quad.uvs)
    return Primitive(np.concatenate(pos), np.concatenate(faces), np.concatenate(nrm), np.concatenate(uvs))


def disk(tolerance: float = TOLERANCE) -> Primitive:
    """A fan around the centre; the rim a regular polygon inscribed in the unit circle."""
    n = segments(tolerance)
    phi = 2.0 * math.pi * np.arange(n) / n
    p = np.concatenate([[[0.0, 0.0, 0.0]], np.stack([np.cos(phi), np.sin(phi), np.zeros(n)], 1)])
    k = np.arange(n)
    faces = np.stack([np.zeros(n, np.int64), 1 + k, 1 + (k + 1) % n], 1).astype(np.int64)
    uv = np.stack([np.concatenate([[0.0], np.ones(n)]), 1.0 - np.concatenate([[0.0], phi / (2 * math.pi)])], 1)
    return Primitive(p, faces, np.tile([0.0, 0.0, 1.0], (n + 1, 1)), uv)


def sphere(tolerance: float = TOLERANCE) -> Primitive:
    """A latitude-longitude sphere: n segments around, n/2 rings, a seam column repeated so that
    uv runs 0..1; the poles are single vertices per segment (fans, no degenerate triangles).
    A cell's triangle is deeper than its edges' sagitta (its circumradius is the cell's half
    diagonal: about twice the depth), so the sphere takes segments(tolerance / 2)."""
    n = segments(tolerance / 2.0)
    rings = max(n // 2, 2)
    theta = math.pi * np.arange(rings + 1) / rings            # 0 at +z
    phi = 2.0 * math.pi * np.arange(n + 1) / n                 # seam repeated
    t, f = np.meshgrid(theta, phi, indexing="ij")             # (rings+1, n+1)
    p = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1).reshape(-1, 3)
    uv = np.stack([f / (2 * math.pi), 1.0 - t / math.pi], -1).reshape(-1, 2)
    p[:n + 1] = [0.0, 0.0, 1.0]
    p[-(n + 1):] = [0.0, 0.0, -1.0]
    # Cells between ring i (index i*(n+1)+j) and ring i+1; outward = counter-clockwise.
    i, j = np.meshgrid(np.arange(rings), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    b, c, d = a + (n + 1), a + (n + 2), a + 1
    ring = np.repeat(np.arange(rings), n)
    lower = np.stack([a, b, c], 1)[ring < rings - 1]  # b, c are both the south pole on the last ring
    upper = np.stack([a, c, d], 1)[ring > 0]          # a, d are both the north pole on the first
    faces = np.concatenate([lower, upper]).astype(np.int64)
    return Primitive(p, faces, p.copy(), uv)


def cylinder(tolerance: float = TOLERANCE) -> Primitive:
    """The open side of the unit cylinder, one band of 2n triangles (the side is straight in z)."""
    n = segments(tolerance)
    phi = 2.0 * math.pi * np.arange(n + 1) / n
    f, z = np.meshgrid(phi, [0.0, 1.0], indexing="ij")        # (n+1, 2): index i*2 + j
    p = np.stack([np.cos(f), np.sin(f), z], -1).reshape(-1, 3)
    normals = p * [1.0, 1.0, 0.0]
    uv = np.stack([f / (2 * math.pi), 1.0 - z], -1).reshape(-1, 2)
    return Primitive(p, _grid(n, 1), normals, uv)


def triangle_count(kind: str, tolerance: float = TOLERANCE) -> int:
    """Triangles of ``make(kind, tolerance)``, without making it (issue #24: a scene's size is
    checked before any geometry is built; tests/test_scene_size.py holds each count to its
    tessellation). None of these shapes has a degenerate triangle for mesh.assemble to drop."""
    if kind == "rectangle":
        return 2
    if kind == "cube":
        return 12
    if kind == "disk":
        return segments(tolerance)
    if kind == "cylinder":
        return 2 * segments(tolerance)
    if kind == "sphere":  # rings - 1 bands of n cells, each 2 triangles, less the poles' half cells
        n = segments(tolerance / 2.0)
        return 2 * n * (max(n // 2, 2) - 1)
    raise ValueError(f"unknown primitive {kind!r} (known: {', '.join(KINDS)})")


def make(kind: str, tolerance: float = TOLERANCE) -> Primitive:
    """The primitive named ``kind`` (one of :data:`KINDS`)."""
    if kind == "rectangle":
        return rectangle()
    if kind == "cube":
        return cube()
    if kind in ("disk", "sphere", "cylinder"):
        return {"disk": disk, "sphere": sphere, "cylinder": cylinder}[kind](tolerance)
    raise ValueError(f"unknown primitive {kind!r} (known: {', '.join(KINDS)})")


def flipped(prim: Primitive) -> Primitive:
    """The same surface facing the other way (Mitsuba's ``flip_normals``)."""
    return Primitive(prim.positions, prim.faces[:, [0, 2, 1]], -prim.normals, prim.uvs)
