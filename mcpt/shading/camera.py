"""Pinhole camera basis (GLSL side: glsl/camera.glsl), following scene.json's convention:

    f = normalize(look_at - position); r = normalize(cross(f, up)); u = cross(r, f)
    x = (2 (i + sx) / W - 1) tan(vfov/2) W/H,  y = (1 - 2 (j + sy) / H) tan(vfov/2)
    direction = normalize(f + x r + y u)

The host pre-scales r by tan(vfov/2) W/H and u by tan(vfov/2) so the shader does one multiply-add.
Computed in float64; the camera position becomes the origin of the uploaded geometry.

(sx, sy) is uniform in the pixel (box filter) or drawn from the pixel filter (tent, Gaussian:
mcpt/shading/pixel_filter.py), which :func:`camera_uses` compiles in only when the scene asks.
"""

from __future__ import annotations

import math

import numpy as np

from .pixel_filter import table


def orthonormal(position, look_at, up):
    """(forward, right, up) unit float64 vectors of the convention above."""
    f = np.subtract(look_at, position, dtype=np.float64)
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(up, np.float64))
    r /= np.linalg.norm(r)
    return f, r, np.cross(r, f)


def basis(position, look_at, up, vfov_deg: float, width: int, height: int):
    """(forward, right_scaled, up_scaled) float64 vectors: what the shader's uniforms hold."""
    f, r, u = orthonormal(position, look_at, up)
    t = math.tan(math.radians(vfov_deg) / 2.0)
    return f, r * (t * width / height), u * t



def camera_uses(cam) -> dict:
    """The ``Uses`` fields (mcpt/gpu/features.py) of a scene's camera model."""
    return {"pixel_filter": cam.filter.type != "box"}


def camera_uniforms(cam) -> dict:
    """Every camera uniform of glsl/camera.glsl (and glsl/pixel_filter.glsl) for ``cam``."""
    f, r, u = basis(cam.position, cam.look_at, cam.up, cam.vfov_deg, cam.width, cam.height)
    out = {"u_cam_forward": tuple(f), "u_cam_right": tuple(r), "u_cam_up": tuple(u),
           "u_resolution": (cam.width, cam.height)}
    if cam.filter.type != "box":
        out.update(table(cam.filter.type, cam.filter.std, cam.filter.tent_radius))
    return out


def camera_summary(cam) -> dict:
    """What ``mcpt info`` says of the camera: its model and the pixel filter compiled in."""
    return {"model": "pinhole", "filter": cam.filter.describe()}
