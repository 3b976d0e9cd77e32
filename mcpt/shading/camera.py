"""The camera's rays (GLSL side: glsl/camera.glsl), following scene.json's convention:

    f = normalize(look_at - position); r = normalize(cross(f, up)); u = cross(r, f)
    x = 2 (i + sx) / W - 1,  y = 1 - 2 (j + sy) / H         (film position in [-1, 1]^2)

* pinhole: direction normalize(f + x r' + y u') with r' = r tan(vfov/2) W/H, u' = u tan(vfov/2).
* thin lens (Mitsuba's ``thinlens``, src/sensors/thinlens.cpp): origin a = R (dx r + dy u) for
  (dx, dy) uniform on the unit disk (Shirley & Chiu's concentric map), R the aperture radius;
  direction normalize(D (f + x r' + y u') - a), D the focus distance: every lens point of a film
  position aims at the point the pinhole ray meets on the plane D ahead, which stays sharp.
* orthographic (Mitsuba's ``orthographic``): origin x r'' + y u'' with r'' = r h W / (2 H),
  u'' = u h / 2 (h the view height), direction f.

The host pre-scales r and u (the uniforms) so the shader does one multiply-add. Computed in float64;
the camera position becomes the origin of the uploaded geometry. (sx, sy) is uniform in the pixel
(box filter) or drawn from the pixel filter (tent, Gaussian: mcpt/shading/pixel_filter.py). Only
what the scene's camera is (:func:`camera_uses`) is compiled in.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import McptError
from .pixel_filter import FILTER_IDS, uniforms

#: An aperture radius above this many times the scene's size is refused (a typo, not a lens:
#: everything would be a blur of the whole scene).
MAX_APERTURE_PER_SCENE = 1.0


class CameraError(McptError):
    """A camera that the scene cannot be rendered through (one line naming the key)."""


def orthonormal(position, look_at, up):
    """(forward, right, up) unit float64 vectors of the convention above."""
    f = np.subtract(look_at, position, dtype=np.float64)
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(up, np.float64))
    r /= np.linalg.norm(r)
    return f, r, np.cross(r, f)


def basis(position, look_at, up, vfov_deg: float, width: int, height: int):
    """(forward, right_scaled, up_scaled) float64 vectors of a pinhole: what the uniforms hold."""
    f, r, u = orthonormal(position, look_at, up)
    t = math.tan(math.radians(vfov_deg) / 2.0)
    return f, r * (t * width / height), u * t


def vertical_fov(fov_deg: float, axis: str, aspect: float) -> float:
    """The vertical field of view (degrees) of a field of view ``fov_deg`` measured along ``axis``
    (Mitsuba's ``fov_axis``: x, y, diagonal, smaller, larger) of an image ``aspect = W / H``
    wide: tan(v/2) = tan(fov/2) / (aspect, 1, sqrt(1 + aspect^2)) by the axis's length."""
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    length = {"x": aspect, "y": 1.0, "diagonal": math.hypot(1.0, aspect)}[axis]
    return 2.0 * math.degrees(math.atan(math.tan(math.radians(fov_deg) / 2.0) / length))


def camera_uses(cam) -> dict:
    """The ``Uses`` fields (mcpt/gpu/features.py) of a scene's camera."""
    return {"pixel_filter": FILTER_IDS[cam.filter.type], "thin_lens": thin_lens(cam),
            "orthographic": cam.projection == "orthographic"}


def thin_lens(cam) -> bool:
    """A lens with an aperture (radius 0 is a pinhole, compiled as one)."""
    return cam.lens is not None and cam.lens.radius > 0.0


def camera_uniforms(cam) -> dict:
    """Every camera uniform of glsl/camera.glsl (and glsl/pixel_filter.glsl) for ``cam``."""
    if cam.projection == "orthographic":
        f, r, u = orthonormal(cam.position, cam.look_at, cam.up)
        half = 0.5 * cam.ortho_height
        r, u = r * (half * cam.width / cam.height), u * half
    else:
        f, r, u = basis(cam.position, cam.look_at, cam.up, cam.vfov_deg, cam.width, cam.height)
    out = {"u_cam_forward": tuple(f), "u_cam_right": tuple(r), "u_cam_up": tuple(u),
           "u_resolution": (cam.width, cam.height)}
    if thin_lens(cam):
        _, ru, uu = orthonormal(cam.position, cam.look_at, cam.up)
        out.update(u_lens_right=tuple(ru * cam.lens.radius), u_lens_up=tuple(uu * cam.lens.radius),
                   u_focus_distance=float(cam.lens.focus_distance))
    if cam.filter.type != "box":
        out.update(uniforms(cam.filter.type, cam.filter.std, cam.filter.tent_radius))
    return out


def check_camera(scene, tris: np.ndarray) -> None:
    """Refuse an aperture larger than the scene (``tris``: camera-relative corners), in one line."""
    cam = scene.camera
    if not thin_lens(cam) or len(tris) == 0:
        return
    pts = tris.reshape(-1, 3)
    size = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    if cam.lens.radius > MAX_APERTURE_PER_SCENE * size:
        raise CameraError(f"{scene.where('camera', 'lens')}: aperture radius {cam.lens.radius:g} is "
                          f"larger than the whole scene ({size:g} across): not a lens")


def camera_summary(cam) -> dict:
    """What ``mcpt info`` says of the camera: its model and the pixel filter compiled in."""
    if cam.projection == "orthographic":
        model = f"orthographic (view height {cam.ortho_height:g})"
    elif thin_lens(cam):
        model = cam.lens.describe()
    else:
        model = "pinhole"
    return {"model": model, "filter": cam.filter.describe()}
