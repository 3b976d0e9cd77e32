"""Float textures (issue #22): OpenEXR and Radiance ``.hdr`` images and 16-bit PNGs, read as
linear values and kept as one RGBA32F texel per pixel (float bits in the ``textures`` buffer,
header flag FLAG_FLOAT: mcpt/shading/texture.py, glsl/texture.glsl ``tex_pixel``).

What the values mean follows Mitsuba 3's Bitmap (src/core/bitmap.cpp):

* EXR and HDR are float images and linear: no sRGB curve, whatever the texture's encoding says
  (Mitsuba's float bitmaps have ``srgb_gamma`` false, and ``raw`` changes nothing for them).
* a 16-bit PNG is sRGB-encoded like an 8-bit one (``read_png`` sets ``m_srgb_gamma = true`` for
  both depths): a colour map is sRGB-decoded here, on the host, in float64 from c / 65535 and
  then rounded to float32 (all 16 bits kept: they were rounded to 8 before); a texture read
  linearly (normal maps, metallic-roughness, ``encoding: linear``, an alpha channel) is c / 65535.

Refused in one line naming the file (:class:`~mcpt.shading.texture.TextureError`): NaN, infinite
or negative texels (as environment maps refuse them: mcpt/shading/envmap_file.py), an image
with no R, G, B (or Y) channels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .envmap_file import _read_exr, check_texels
from .image_header import png_bit_depth

FLOAT_SUFFIXES = (".exr", ".hdr")


def is_float_file(path: Path) -> bool:
    """Whether the image becomes a float texture: EXR, HDR, or a 16-bit PNG (from its header)."""
    try:
        return Path(path).suffix.lower() in FLOAT_SUFFIXES or png_bit_depth(path) == 16
    except OSError:
        return False


def read_float_file(path: Path, alpha: bool, error: type[Exception]) -> np.ndarray:
    """(H, W, 3) float32 linear values of an EXR or HDR file, row 0 at the top; ``alpha``: the
    alpha channel (1 where there is none) in all three."""
    if path.suffix.lower() == ".exr":
        img = _read_exr(path, error, alpha=alpha)
    else:
        import cv2

        bgr = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if bgr is None or bgr.ndim != 3 or bgr.dtype != np.float32:
            raise error(f"{path}: not a Radiance .hdr image OpenCV can read, or unreadable")
        img = np.ones_like(bgr) if alpha else np.ascontiguousarray(bgr[:, :, 2::-1])
    check_texels(img, str(path), "a float texture", "values", error)
    return img


def from_16bit(img: np.ndarray, linear: bool) -> np.ndarray:
    """(H, W, 3) float32 of 16-bit texels: sRGB-decoded from c / 65535 in float64 (Mitsuba's
    reading of a 16-bit PNG), or c / 65535 when read linearly. Through a 65536-entry float32
    table: the same values as the curve per texel, without its float64 temporaries (a 2048^2
    PNG's load peaked at 106 bytes a pixel through them)."""
    c = np.arange(65536) / 65535.0
    if not linear:
        c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return c.astype(np.float32)[img]
