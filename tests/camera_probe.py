"""Shared by tests/test_camera.py and tests/test_pixel_filter.py (no tests of its own): a camera
model, a scene file around a camera, and tests/glsl/probe_camera.frag run on the real camera GLSL."""

from __future__ import annotations

import numpy as np

from mcpt.gpu.features import Features
from mcpt.scene.model import Camera
from mcpt.shading.camera import camera_uniforms, camera_uses

from .probes import run_test_probe
from .test_materials_util import floats

RES = 16   # the probe camera's image size, pixels


def camera(**extra) -> Camera:
    return Camera.model_validate({"position": (0.0, 0.0, 0.0), "look_at": (0.0, 0.0, -1.0),
                                  "vfov_deg": 50.0, "resolution": (RES, RES), **extra})



def write_scene(tmp_path, camera_lines: str, name="s.yaml"):
    path = tmp_path / name
    path.write_text("camera:\n  position: [0, 0, 1]\n  look_at: [0, 0, 0]\n  resolution: [8, 8]\n"
                    + camera_lines + "meshes:\n  - {shape: sphere}\n")
    return path


def run_camera_probe(gl, cam: Camera, mode: int, u: np.ndarray, pixels: np.ndarray,
                     lens=(0.5, 0.5)) -> np.ndarray:
    """Probe ``mode`` (see the probe's header) over items (u, pixel), lens numbers ``lens``."""
    n = len(u)
    buf = np.zeros((n, 4), np.uint32)
    buf[:, :2] = u.astype(np.float32).view(np.uint32)
    buf[:, 2:] = pixels.astype(np.uint32)
    feats = Features.of(bounces=1, **camera_uses(cam))
    return floats(run_test_probe(gl, "probe_camera.frag", buf, n, preamble=feats.preamble(),
                                 key=("probe_camera", feats.key),
                                 uniforms={"u_mode": mode, "u_lens": tuple(map(float, lens)),
                                           **camera_uniforms(cam)}, width=1024))
