"""Analytic spheres: a ``shape: sphere`` mesh entry intersected exactly in the shader, not tessellated.

A tessellated sphere (mcpt/shapes/primitives.py) costs 32 760 triangles: two of them made the
sky-with-a-sun scene of issue #20 (bench/scenes-xml/lights-envmap-diffuse.xml) 70 % BVH traversal
and 5x slower than Mitsuba 3, which intersects its ``sphere`` analytically (src/shapes/sphere.cpp).
Here a sphere is a centre, a radius and a rotation (for its uv), tested by every ray in a
written-out loop after the triangles (glsl/sphere.glsl). It is used where it shades exactly as the
tessellated one would and more cheaply:

* the placement is a similarity (rotation, uniform scale, translation): otherwise the entry is an
  ellipsoid, which stays tessellated;
* its material is not an emitter (area lights sample triangles: mcpt/shading/lights.py), has no
  normal or bump map and no opacity cut-out (those read triangle tangents / pass through
  triangles);
* at most :data:`MAX_SPHERES` per scene (each costs every ray a test; the rest stay tessellated),
  and the scene keeps at least one triangle (the triangle buffers are never empty).

Layout (glsl/sphere.glsl reads it): five RGBA32UI texels per sphere,
    (centre.x, centre.y as float64 bits), (centre.z as float64 bits, radius as float32 bits, material id),
    (rotation column 0, +1.0 or -1.0: -1 when the normals are flipped), (column 1, 0), (column 2, 0)
with the centre relative to the camera in float64 (the shader intersects in double precision:
glsl/sphere.glsl says why) and the rotation the placement's linear part divided by the radius, so
that the sphere's own coordinates of a world direction n are (col0 . n, col1 . n, col2 . n) --
Mitsuba's uv frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Most analytic spheres a scene compiles (each ray tests every one: glsl/sphere.glsl).
MAX_SPHERES = 16
#: Texels per sphere in the packed buffer.
TEXELS = 5


@dataclass(frozen=True)
class Sphere:
    """One analytic sphere: centre (world units, float64, before rebasing), radius (world units),
    rotation (3, 3) orthogonal (its own frame's axes as columns), flipped normals."""

    center: np.ndarray
    radius: float
    rotation: np.ndarray
    flip: bool = False


def placed_sphere(matrix: np.ndarray, flip: bool = False) -> Sphere | None:
    """The sphere that the unit sphere placed by ``matrix`` (4 x 4) is, or None when the matrix
    is not a similarity (an ellipsoid, a shear, a projective row) and the shape must stay a mesh."""
    m = np.asarray(matrix, np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)) or not np.allclose(m[3], [0, 0, 0, 1]):
        return None
    a = m[:3, :3]
    gram = a.T @ a
    s2 = float(np.mean(np.diag(gram)))
    if not s2 > 0 or not np.allclose(gram, s2 * np.eye(3), rtol=1e-6, atol=1e-9 * s2):
        return None
    r = float(np.sqrt(s2))
    return Sphere(m[:3, 3].copy(), r, a / r, bool(flip))


def pack_spheres(spheres: list[Sphere], materials: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(TEXELS * S, 4) uint32 texels of ``spheres`` (layout: module doc), centres rebased to
    ``origin`` in float64 and kept in float64 (issue #6: precision far from the origin)."""
    out = np.zeros((len(spheres), TEXELS, 4), np.uint32)
    for i, s in enumerate(spheres):
        centre = np.asarray(s.center, np.float64) - np.asarray(origin, np.float64)
        out[i, :2].reshape(-1)[:6] = centre.view(np.uint32)  # (lo, hi) words: GLSL packDouble2x32
        out[i, 1, 2] = np.float32(s.radius).view(np.uint32)
        out[i, 1, 3] = int(materials[i])
        cols = np.zeros((3, 4), np.float32)
        cols[:, :3] = s.rotation.T
        cols[0, 3] = -1.0 if s.flip else 1.0
        out[i, 2:] = cols.view(np.uint32)
    return out.reshape(-1, 4)


def sphere_bounds(spheres: list[Sphere], origin: np.ndarray) -> np.ndarray:
    """(2, 3) float64 corners of the box around ``spheres``, relative to ``origin``."""
    c = np.array([s.center for s in spheres], np.float64) - np.asarray(origin, np.float64)
    r = np.array([s.radius for s in spheres], np.float64)[:, None]
    return np.stack([(c - r).min(axis=0), (c + r).max(axis=0)])
