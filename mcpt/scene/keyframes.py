"""Keyframe interpolation: one channel (a vector, a scalar or a rotation) sampled at a frame.

A :class:`Track` holds strictly increasing key frames and their values (float64). Between keys:

* ``linear``: ``v_i + (v_{i+1} - v_i) s``, ``s = (t - t_i) / (t_{i+1} - t_i)``; rotations slerp.
* ``smooth``: cubic Hermite with Catmull-Rom tangents for non-uniform spacing,
  ``m_i = (v_{i+1} - v_{i-1}) / (t_{i+1} - t_{i-1})`` (one-sided at the ends) -- E. Catmull,
  R. Rom, "A class of local interpolating splines", 1974; rotations use Shoemake's squad with
  the inner quadrangle points ``s_i = q_i exp(-(log(q_i^-1 q_{i+1}) + log(q_i^-1 q_{i-1})) / 4)``
  (K. Shoemake, "Animating rotation with quaternion curves", SIGGRAPH 1985; the uniform-spacing
  form, so a rotation's speed follows the key spacing only approximately).

Every key is hit exactly: at ``t = t_i`` the weights are exactly (1, 0, 0, 0) and slerp's
``sin(theta) / sin(theta)`` is exactly 1 (tests/test_animation.py checks bit equality). Before the
first key a channel holds the first key's value, after the last the last's (no extrapolation).

Quaternions are ``(x, y, z, w)`` (glTF's order), normalised when the track is made, each key's
sign chosen in the hemisphere of the one before (q and -q are the same rotation; this makes the
interpolation take the short way).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

MODES = ("linear", "smooth")


@dataclass(frozen=True)
class Track:
    """One animated channel: ``frames`` strictly increasing, ``values`` (keys, n) float64."""

    frames: tuple
    values: np.ndarray
    mode: str = "smooth"
    rotation: bool = False     # values are unit quaternions (x, y, z, w)

    @classmethod
    def make(cls, frames, values, mode: str = "smooth", rotation: bool = False) -> Track:
        v = np.array(values, dtype=np.float64).reshape(len(frames), -1)
        if rotation:
            v /= np.linalg.norm(v, axis=1, keepdims=True)
            for i in range(1, len(v)):
                if np.dot(v[i - 1], v[i]) < 0.0:
                    v[i] = -v[i]
        return cls(tuple(float(f) for f in frames), v, mode, rotation)

    def at(self, t: float) -> np.ndarray:
        """The channel's value at frame ``t`` (a fresh float64 array)."""
        f, v = self.frames, self.values
        if t <= f[0] or len(f) == 1:
            return v[0].copy()
        if t >= f[-1]:
            return v[-1].copy()
        i = bisect.bisect_right(f, t) - 1      # f[i] <= t < f[i + 1]
        s = (t - f[i]) / (f[i + 1] - f[i])
        if self.rotation:
            if self.mode == "linear":
                return slerp(v[i], v[i + 1], s)
            a, b = _inner(v, i), _inner(v, i + 1)
            return slerp(slerp(v[i], v[i + 1], s), slerp(a, b, s), 2.0 * s * (1.0 - s))
        if self.mode == "linear":
            return v[i] + (v[i + 1] - v[i]) * s
        dt = f[i + 1] - f[i]
        m0, m1 = self._tangent(i) * dt, self._tangent(i + 1) * dt
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        return h00 * v[i] + h10 * m0 + h01 * v[i + 1] + h11 * m1

    def _tangent(self, i: int) -> np.ndarray:
        """Catmull-Rom tangent at key ``i`` per frame (one-sided at the ends)."""
        f, v = self.frames, self.values
        lo, hi = max(i - 1, 0), min(i + 1, len(f) - 1)
        return (v[hi] - v[lo]) / (f[hi] - f[lo])


def slerp(a: np.ndarray, b: np.ndarray, s: float) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions (Shoemake 1985), ``s`` in [0, 1]."""
    d = float(np.clip(np.dot(a, b), -1.0, 1.0))
    if d < 0.0:
        b, d = -b, -d
    theta = math.acos(d)
    if theta < 1e-9:             # (nearly) the same rotation: the lerp is exact enough
        q = a + (b - a) * s
        return q / np.linalg.norm(q) if s != 0.0 else a.copy()
    w0, w1 = math.sin((1.0 - s) * theta) / math.sin(theta), math.sin(s * theta) / math.sin(theta)
    return w0 * a + w1 * b


def _qmul(a, b) -> np.ndarray:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def _conj(q) -> np.ndarray:
    return np.array([-q[0], -q[1], -q[2], q[3]])


def _log(q) -> np.ndarray:
    """log of a unit quaternion: (axis * half-angle, 0)."""
    n = float(np.linalg.norm(q[:3]))
    if n < 1e-12:
        return np.zeros(4)
    return np.array([*(q[:3] / n * math.atan2(n, q[3])), 0.0])


def _exp(v) -> np.ndarray:
    n = float(np.linalg.norm(v[:3]))
    if n < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    return np.array([*(v[:3] / n * math.sin(n)), math.cos(n)])


def _inner(v: np.ndarray, i: int) -> np.ndarray:
    """Shoemake's squad inner point of key ``i`` (ends: the key itself)."""
    if i == 0 or i == len(v) - 1:
        return v[i]
    inv = _conj(v[i])
    t = -(_log(_qmul(inv, v[i + 1])) + _log(_qmul(inv, v[i - 1]))) / 4.0
    return _qmul(v[i], _exp(t))


def quat_matrix(q) -> np.ndarray:
    """3x3 rotation matrix of a unit quaternion (x, y, z, w); q and -q give the same bits."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def euler_quat(rotate_deg) -> np.ndarray:
    """The quaternion of mcpt's Euler convention (mcpt/scene/transform.py: Rz Ry Rx)."""
    def axis(k: int, deg: float) -> np.ndarray:
        h = math.radians(deg) / 2.0
        q = np.zeros(4)
        q[k], q[3] = math.sin(h), math.cos(h)
        return q

    x, y, z = rotate_deg
    return _qmul(axis(2, z), _qmul(axis(1, y), axis(0, x)))
