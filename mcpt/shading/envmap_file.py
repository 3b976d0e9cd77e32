"""Reading an environment map image (mcpt/shading/envmap.py builds its sampling tables).

``.exr`` through OpenEXR (channels R, G, B, or Y for a grey map), ``.hdr`` (Radiance RGBE) through
OpenCV, both linear RGB. An 8- or 16-bit ``.png`` / ``.jpg`` is accepted the way Mitsuba 3 accepts
it (its Bitmap converts to linear): the values are sRGB-decoded, so they never exceed 1, and a
note says so once.

Refused, each in one line that names the file (:class:`EnvMapError`):

* a file that is not an image of its kind, or that cannot be read;
* an image too large, found from the file's header *before* decoding (a 100k x 50k EXR would
  otherwise allocate 60 GB first; issue #20 "preflight against memory and GL_MAX_TEXTURE_SIZE"):
  more than :data:`MAX_ENV_TEXELS`; more texels than the GL driver's buffer textures hold (the
  map is uploaded as buffer textures, mcpt/shading/envmap.py EnvMap.pack, not as a 2-D texture,
  so GL_MAX_TEXTURE_BUFFER_SIZE is the limit that applies and GL_MAX_TEXTURE_SIZE does not;
  llvmpipe does not clamp an oversized buffer, so we check); more memory than is available, at
  the measured :data:`ENV_BYTES_PER_TEXEL`;
* NaN, infinite or negative texels, with their count. They are refused rather than clamped: such
  a value is not a radiance, and replacing it would silently change the light the scene gets
  (the user can fix the file; Mitsuba would propagate the NaN into the render).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..errors import McptError
from .image_header import image_size

log = logging.getLogger("mcpt")

#: The most texels an environment map may have (2^26: 11585^2, or 16384 x 4096). Its buffer
#: texture holds one RGBA32 texel per image texel (1 GiB at the limit), within llvmpipe's
#: GL_MAX_TEXTURE_BUFFER_SIZE of 2^27 texels; the upload checks the driver's own limit again.
MAX_ENV_TEXELS = 1 << 26

#: Peak host bytes per texel of an environment map through ``mcpt render`` (decoded, scaled,
#: its luminance, weights and alias tables, the packed buffers and the driver's copy of them).
#: Measured (``/usr/bin/time -f %M``, 8 x 8 pixels, 1 spp, the icosphere): a 4096 x 2048 map adds
#: 547 MB to a 4 x 2 one's 172 MB as EXR (68 bytes a texel), 561 MB as .hdr (70); 105-107 with
#: the float64 table build before; the set-up cache on changes nothing. Rounded up.
ENV_BYTES_PER_TEXEL = 80

#: Mitsuba's smallest environment map (Bitmap::pad_to(2, 3)): W >= 2, H >= 3.
MIN_WIDTH, MIN_HEIGHT = 2, 3

HDR_SUFFIXES = (".exr", ".hdr")
LDR_SUFFIXES = (".png", ".jpg", ".jpeg")

#: Said once for an 8/16-bit image, after the file name.
LDR_NOTE = "LDR environment: values read as sRGB-decoded, max 1"


class EnvMapError(McptError, ValueError):
    """An environment map cannot be used; the one-line message names the file."""


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


# ------------------------------------------------------------------------------------------------
# Sizes from the headers, before any pixel is decoded


def buffer_texels(width: int, height: int) -> int:
    """Texels of the larger of the map's two buffer textures (EnvMap.pack): ``env_texels``, one
    per texel of the padded image. ``env_alias`` never has more: (H' + (H - 1) W') / 2 + 1 with
    H' < 2 (H - 1), W' < 2 W (powers of two) is below (H - 1) (W - 1) + H <= W H."""
    return max(width, MIN_WIDTH) * max(height, MIN_HEIGHT)


def check_envmap_size(path, size: tuple[int, int] | None, buffer_limit: int | None = None) -> None:
    """Refuse an image of ``size`` (width, height; None: unknown, the decoder decides) that
    cannot be an environment map here: empty, over :data:`MAX_ENV_TEXELS`, over ``buffer_limit``
    texels of a buffer texture (the GL driver's GL_MAX_TEXTURE_BUFFER_SIZE; None: the figure mcpt
    relies on, mcpt/gpu/limits.py), or needing more memory than is available."""
    from ..gpu import host_memory, limits

    if size is None:
        return
    w, h = size
    if w < 1 or h < 1:
        raise EnvMapError(f"{path}: empty image ({w} x {h})")
    if w * h > MAX_ENV_TEXELS:
        raise EnvMapError(f"{path}: {w} x {h} = {w * h} texels; an environment map may have at most "
                          f"{MAX_ENV_TEXELS} (2^26), e.g. 8192 x 4096")
    limit = limits.GL_BUFFER_TEXELS if buffer_limit is None else buffer_limit
    if buffer_texels(w, h) > limit:
        raise EnvMapError(f"{path}: {w} x {h} = {w * h} texels exceed GL_MAX_TEXTURE_BUFFER_SIZE = {limit} "
                          f"(an environment map is a buffer texture, one texel per pixel)")
    need, avail = w * h * ENV_BYTES_PER_TEXEL, host_memory.available_bytes()
    if avail is not None and need > avail:
        raise EnvMapError(f"{path}: {w} x {h} needs about {need / 2**30:.1f} GiB to load, more than the "
                          f"{avail / 2**30:.1f} GiB of memory available")


def check_envmap_file(path, buffer_limit: int | None = None) -> None:
    """:func:`check_envmap_size` of the size in the file's header, nothing decoded (a missing or
    unreadable file is left to the reader, which says so)."""
    try:
        size = image_size(Path(path), EnvMapError)
    except OSError:
        return
    check_envmap_size(path, size, buffer_limit)


# ------------------------------------------------------------------------------------------------
# Decoding


def _read_exr(path: Path, error: type[Exception] = EnvMapError, alpha: bool = False) -> np.ndarray:
    """(H, W, 3) float32 R, G, B (or Y) of an EXR, row 0 at the top; ``alpha``: its A channel
    (1 where it has none) in all three (a texture's opacity, mcpt/shading/float_texture.py)."""
    import OpenEXR

    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            ch = {k: np.asarray(v.pixels) for k, v in f.channels().items()}
    except (RuntimeError, OSError, ValueError) as exc:
        raise error(f"{path}: not an OpenEXR image, or unreadable ({_one_line(exc)})") from None
    if alpha:
        a = ch.get("A")
        shape = next(iter(ch.values())).shape if ch else (0, 0)
        return np.repeat((np.asarray(a, np.float32) if a is not None else np.ones(shape, np.float32))[..., None],
                         3, axis=-1)
    if all(c in ch for c in "RGB"):
        planes = [ch[c] for c in "RGB"]
    elif "Y" in ch:
        planes = [ch["Y"]] * 3
    else:
        names = ", ".join(sorted(ch)[:6])
        raise error(f"{path}: no R, G, B (or Y) channels in the EXR; it has {names}")
    return np.stack([np.asarray(p, np.float32) for p in planes], axis=-1)


def _srgb_decode(x: np.ndarray) -> np.ndarray:
    """The sRGB curve (IEC 61966-2-1) on values in [0, 1]."""
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _read_cv2(path: Path, hdr: bool) -> np.ndarray:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    kind = "a Radiance .hdr image" if hdr else "a PNG or JPEG image"
    if img is None:
        raise EnvMapError(f"{path}: not {kind} OpenCV can read, or unreadable")
    if img.ndim == 2:
        img = img[:, :, None]
    if img.shape[2] in (1, 2):   # grey (+ alpha)
        img = np.repeat(img[:, :, :1], 3, axis=2)
    else:
        img = img[:, :, 2::-1]   # BGR(A) -> RGB
    if hdr:
        return np.ascontiguousarray(img, np.float32)
    if img.dtype == np.uint8:
        return _srgb_decode(img / 255.0).astype(np.float32)
    if img.dtype == np.uint16:
        return _srgb_decode(img / 65535.0).astype(np.float32)
    raise EnvMapError(f"{path}: {img.dtype} pixels; an LDR environment map must be 8- or 16-bit")


def check_texels(img: np.ndarray, where: str, what: str = "an environment map", holds: str = "radiance",
                 error: type[Exception] = EnvMapError) -> float:
    """Refuse NaN, infinite or negative texels, with their count (``where`` names the source;
    ``what`` / ``holds`` / ``error``: a surface texture's words and error class); else return
    the largest texel value."""
    lo, hi = float(img.min()), float(img.max())  # NaN propagates through min / max
    if np.isfinite(lo) and np.isfinite(hi) and lo >= 0.0:
        return hi
    finite = np.isfinite(img).all(axis=-1)
    bad = int(img.shape[0] * img.shape[1] - np.count_nonzero(finite))
    negative = int(np.count_nonzero((np.where(finite[..., None], img, 0.0) < 0.0).any(axis=-1)))
    if bad or negative:
        counts = [f"{bad} NaN or infinite" if bad else "", f"{negative} negative" if negative else ""]
        raise error(f"{where}: {' and '.join(w for w in counts if w)} texels of "
                    f"{img.shape[1]} x {img.shape[0]}; {what} must hold finite, non-negative {holds}")


def read_envmap_image(path: str | Path) -> tuple[np.ndarray, str | None]:
    """(H, W, 3) float32 linear RGB, row 0 = the image's top row, and the LDR note (None for an
    HDR image). Every refusal is an :class:`EnvMapError` naming the file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in HDR_SUFFIXES + LDR_SUFFIXES:
        raise EnvMapError(f"{path}: unknown environment map format {path.suffix or '(none)'!r}; "
                          f"use .exr or .hdr (or .png / .jpg)")
    if not path.is_file():
        raise EnvMapError(f"{path}: environment map not found")
    check_envmap_file(path)
    try:
        if suffix == ".exr":
            img = _read_exr(path)
        else:
            img = _read_cv2(path, hdr=suffix == ".hdr")
    except OSError as exc:
        raise EnvMapError(f"{path}: cannot read: {_one_line(exc.strerror or exc)}") from None
    check_envmap_size(path, (img.shape[1], img.shape[0]))
    check_texels(img, str(path))
    return img, (LDR_NOTE if suffix in LDR_SUFFIXES else None)


def read_envmap(path: str | Path) -> np.ndarray:
    """(H, W, 3) float32 linear RGB of an environment map file (:func:`read_envmap_image`); an
    LDR file is accepted with one warning on the ``mcpt`` logger."""
    img, note = read_envmap_image(path)
    if note:
        log.warning("%s: %s", path, note)
    return img
