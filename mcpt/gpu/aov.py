"""Arbitrary output variables (AOVs): albedo, normal, depth and variance layers beside the beauty
(GLSL side: glsl/aov.glsl, which documents what each sample adds).

The shader writes two extra RGBA32F targets summed like the beauty (after the squares target when
there is one): A = (albedo.rgb, depth), B = (normal.xyz, events), where "events" counts the
samples that added their AOVs. They are read back and added in float64 on the same pass grid as
the beauty (mcpt/gpu/render.py), and the means are the sums divided by the events. Variance needs
no target of its own: it is the beauty's variance of the mean (the squares target).

Layers are written into the EXR as ``layer.channel`` (the convention of OpenEXR, Nuke, Blender and
OIDN's tools): ``albedo.R/G/B``, ``normal.X/Y/Z``, ``depth.Z``, ``variance.R/G/B``.
"""

from __future__ import annotations

import numpy as np

from ..errors import McptError

# name -> (EXR channel letters, what it holds); the order is the order of the layers in a file.
AOVS = {
    "albedo": ("RGB", "reflectance in [0, 1] at the first non-specular vertex (mirror and glass "
                      "bounces followed to it); 0 where nothing non-specular is found"),
    "normal": ("XYZ", "world-space unit shading normal at that vertex, turned towards the incoming "
                      "ray; 0 where nothing non-specular is found"),
    "depth": ("Z", "distance from the camera along the camera ray to its first hit [scene units]; "
                   "0 where the ray escapes"),
    "variance": ("RGB", "per-pixel variance of the mean of the beauty (sample variance / spp)"),
}
# What OIDN is fed beside the beauty (mcpt/output/denoise.py).
DENOISE_AOVS = ("albedo", "normal")
AOV_TARGETS = 2  # render targets the shader adds for albedo, normal and depth


class AovError(McptError, ValueError):
    pass


def parse(text) -> tuple[str, ...]:
    """``"albedo,depth"`` (or a list of names) -> ``("albedo", "depth")`` in the canonical order;
    unknown names refused."""
    if not text:
        return ()
    if not isinstance(text, str):
        text = ",".join(text)
    names = {t.strip().lower() for t in text.split(",") if t.strip()}
    unknown = sorted(names - set(AOVS))
    if unknown:
        raise AovError(f"unknown AOV {', '.join(map(repr, unknown))}; choose from {', '.join(AOVS)}")
    return tuple(n for n in AOVS if n in names)


def needs_targets(names) -> bool:
    """Whether the shader must write the AOV targets (variance only uses the squares target)."""
    return any(n in ("albedo", "normal", "depth") for n in names)


def means(a: np.ndarray, b: np.ndarray) -> dict[str, np.ndarray]:
    """float64 sums of targets A and B, each (H, W, 4) -> albedo (H, W, 3), normal (H, W, 3),
    depth (H, W, 1), float32. The normal is the mean normal scaled back to unit length (a pixel
    straddling an edge averages two directions); 0 where no sample found a surface."""
    events = np.maximum(b[..., 3:4], 1.0)
    albedo = a[..., :3] / events
    depth = a[..., 3:4] / events
    normal = b[..., :3] / events
    length = np.linalg.norm(normal, axis=-1, keepdims=True)
    normal = normal * np.divide(1.0, length, out=np.zeros_like(length), where=length > 1e-12)
    return {"albedo": albedo.astype(np.float32), "normal": normal.astype(np.float32),
            "depth": depth.astype(np.float32)}


def layers(values: dict[str, np.ndarray], names) -> dict[str, tuple[np.ndarray, str]]:
    """The ``layers`` argument of mcpt.output.image.write_exr for the AOVs ``names``."""
    return {n: (values[n], AOVS[n][0]) for n in names if n in values}


def channel_names(names) -> list[str]:
    """``["albedo.R", "albedo.G", ...]``: the EXR channels the AOVs ``names`` add."""
    return [f"{n}.{c}" for n in names for c in AOVS[n][0]]
