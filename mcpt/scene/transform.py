"""Placement of a mesh in the scene: translate / rotate / scale or a 4x4 matrix."""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from .diagnostics import FieldError
from .fields import Matrix4, StrictModel, Vec3, scalar_to_vec3


class Transform(StrictModel):
    """Placement of a mesh: either translate/rotate/scale, or a full ``matrix``.

    Points are column vectors, ``p' = M p``, with ``M = T · Rz · Ry · Rx · S``: scale first, then
    rotate about X, then Y, then Z (all about the origin), then translate.
    """

    translate: Vec3 | None = None
    """Offset, world units."""
    rotate_deg: Vec3 | None = None
    """Euler angles in degrees, applied about X, then Y, then Z (right-handed, counter-clockwise)."""
    scale: Annotated[Vec3, BeforeValidator(scalar_to_vec3)] | None = None
    """Uniform factor or ``[sx, sy, sz]``; every factor nonzero (negative mirrors the mesh)."""
    rows: Matrix4 | None = Field(default=None, alias="matrix")
    """YAML key ``matrix``: 4x4 row-major affine matrix, last row ``[0, 0, 0, 1]``; excludes the
    three above. (Stored as ``rows`` because :meth:`matrix` is the composed result.)"""

    @model_validator(mode="after")
    def _check(self) -> Transform:
        if self.rows is not None:
            both = [k for k in ("translate", "rotate_deg", "scale") if getattr(self, k) is not None]
            if both:
                raise FieldError(("matrix",), f"matrix cannot be combined with {', '.join(both)}")
            m = np.asarray(self.rows, dtype=np.float64)
            if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
                # Projective matrices would break normals and area-light sampling; affine only.
                raise FieldError(("matrix", 3), f"last row must be [0, 0, 0, 1], got {m[3].tolist()}")
            a = m[:3, :3]
            # Relative test, so a legitimately tiny (but well-conditioned) scale is still accepted.
            if abs(np.linalg.det(a)) <= 1e-12 * max(float(np.abs(a).max()), 1e-300) ** 3:
                raise FieldError(("matrix",), "matrix is singular (its 3x3 part has zero determinant)")
        if self.scale is not None and 0.0 in self.scale:
            # A zero factor flattens the mesh: degenerate triangles, undefined normals.
            raise FieldError(("scale",), f"scale must be nonzero, got {list(self.scale)}")
        return self

    def matrix(self) -> np.ndarray:
        """The 4x4 float64 object-to-world matrix (a fresh array; identity if nothing is set)."""
        if self.rows is not None:
            return np.array(self.rows, dtype=np.float64)
        t = np.eye(4)
        if self.translate is not None:
            t[:3, 3] = self.translate
        r = np.eye(4)
        if self.rotate_deg is not None:
            ax, ay, az = np.radians(self.rotate_deg)
            r[:3, :3] = _rot_z(az) @ _rot_y(ay) @ _rot_x(ax)
        s = np.eye(4)
        if self.scale is not None:
            s[:3, :3] = np.diag(self.scale)
        return t @ r @ s


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

