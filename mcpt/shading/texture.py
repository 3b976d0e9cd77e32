"""Image textures (GLSL side: glsl/texture.glsl).

8-bit images are read with OpenCV (grey, RGB or RGBA, alpha ignored) and kept **sRGB-encoded**,
8 bits per channel: the shader decodes each texel to linear
RGB with the exact sRGB curve and filters in linear RGB, like a GPU's SRGB8 texture. That keeps a
texel at 4 bytes and every decoded value exact (a float16 copy would take 8). EXR, HDR and
16-bit images are **float textures** (issue #22, mcpt/shading/float_texture.py): linear values,
one RGBA32F texel per pixel.

All textures of a scene share one RGBA32UI buffer texture ("textures", mcpt/gpu/tbo.py):

    texel j < n:        header of texture j: (first data texel, width, height, flags)
                        flags: bits 0-1 wrap (0 repeat, 1 clamp, 2 mirror), bit 2 nearest filter,
                        bit 3 a UV transform leads the data, bit 4 procedural checkerboard,
                        bit 5 linear (c / 255, not sRGB-decoded: normal maps),
                        bit 6 float (one texel per pixel: R, G, B, 0 as float bits, linear)
    [transform]:        with bit 3, 2 texels of float bits (a, b, c, d), (e, f, 0, 0): the lookup
                        reads (a u + b v + c, d u + e v + f) (Mitsuba's ``to_uv``; uv_transform)
    data texels:        4 pixels per texel, one uint each: R | G << 8 | B << 16 | A << 24 (sRGB),
                        rows from the BOTTOM of the image (texel row y holds v in [y, y+1) / height);
                        a float texture: one texel per pixel, the same order;
                        a checkerboard: its two colours instead (mcpt/shading/checkerboard.py)

so texture coordinates (u, v) with v up (the OBJ convention) address pixel (u W - 1/2, v H - 1/2)
directly. A plain buffer texture rather than a sampler2D: no extra binding in the renderer and no
atlas packing, and every mcpt buffer is then checked against the same GL limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import McptError

WRAP = {"repeat": 0, "clamp": 1, "mirror": 2}
FLAG_NEAREST = 4
FLAG_TRANSFORM = 8     # 2 texels of UV transform lead the data
FLAG_CHECKERBOARD = 16  # procedural: the data are two colours (mcpt/shading/checkerboard.py)
FLAG_LINEAR = 32        # texels are linear values c / 255 (normal maps), not sRGB
FLAG_FLOAT = 64         # issue #22: one RGBA32F texel per pixel, linear (EXR, HDR, 16-bit PNG)
IDENTITY_UV = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


class TextureError(McptError, ValueError):
    """An image cannot be used as a texture; the message names the file."""


@dataclass(frozen=True)
class Texture:
    path: Path
    wrap: str
    filter: str
    srgb: np.ndarray | None  # (H, W, 3) uint8, sRGB-encoded, row 0 = BOTTOM of the image (v = 0); None: float
    uv: tuple = IDENTITY_UV  # 2x3 affine map applied to the UVs before the lookup (v up)
    linear: bool = False     # texels are c / 255 (a normal map), not sRGB-encoded
    values: np.ndarray | None = None  # a float texture's (H, W, 3) float32 linear values, row 0 = BOTTOM
    channels: int = 3        # the file's colour channels (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA)

    @property
    def is_float(self) -> bool:
        return self.values is not None

    @property
    def pixels(self) -> np.ndarray:
        return self.values if self.values is not None else self.srgb

    @property
    def width(self) -> int:
        return int(self.pixels.shape[1])

    @property
    def height(self) -> int:
        return int(self.pixels.shape[0])

    @property
    def flags(self) -> int:
        transformed = FLAG_TRANSFORM if not is_identity(self.uv) else 0
        kind = FLAG_FLOAT if self.is_float else (FLAG_LINEAR if self.linear else 0)
        return WRAP[self.wrap] | (FLAG_NEAREST if self.filter == "nearest" else 0) | transformed | kind

    def texels(self) -> np.ndarray:
        """The data texels: the UV transform if any, then the pixels, 4 per texel (a float
        texture: one per texel, R, G, B, 0 as float bits)."""
        if self.is_float:
            px = np.zeros((self.width * self.height, 4), np.float32)
            px[:, :3] = self.values.reshape(-1, 3)
            px = px.view(np.uint32)
        else:
            rgb = self.srgb.reshape(-1, 3).astype(np.uint32)
            px = rgb[:, 0] | (rgb[:, 1] << 8) | (rgb[:, 2] << 16) | np.uint32(0xFF000000)
            px = np.concatenate([px, np.zeros((-px.size) % 4, np.uint32)]).reshape(-1, 4)
        return np.concatenate([uv_texels(self.uv), px]) if self.flags & FLAG_TRANSFORM else px

    def decoded(self) -> np.ndarray:
        """(H, W, 3) float64 values the shader filters: sRGB-decoded, or c / 255 if linear, or a
        float texture's values. Through a 256-entry table (the same values as decoding each
        texel: one float64 array, not the five temporaries of the curve, which made a 4096^2
        texture's set-up peak ~1.8 GB)."""
        if self.is_float:
            return self.values.astype(np.float64)
        lut = np.arange(256) / 255.0 if self.linear else srgb_to_linear(np.arange(256))
        return lut[self.srgb]

    def mean_linear(self) -> np.ndarray:
        return self.decoded().reshape(-1, 3).mean(axis=0)


def is_identity(uv) -> bool:
    return np.array_equal(np.asarray(uv, np.float64), np.asarray(IDENTITY_UV))


def uv_texels(uv) -> np.ndarray:
    """The 2 texels of a 2x3 UV transform (float32 bits): (a, b, c, d), (e, f, 0, 0)."""
    m = np.asarray(uv, np.float32).reshape(2, 3)
    out = np.zeros(8, np.float32)
    out[:6] = m.ravel()
    return out.view(np.uint32).reshape(2, 4)


def apply_uv(uv_map, uv: np.ndarray) -> np.ndarray:
    """The 2x3 affine ``uv_map`` applied to (N, 2) texture coordinates (float64)."""
    m = np.asarray(uv_map, np.float64).reshape(2, 3)
    return np.asarray(uv, np.float64) @ m[:, :2].T + m[:, 2]


#: The most pixels an image texture may have (2^26: 8192 x 8192, one uint each in the textures
#: buffer, 256 MiB; a float texture's pixel takes four, 1 GiB), found from the file's header before
#: decoding (issue #22: a 20000^2 PNG was killed for memory, a 40000^2 one ended in OpenCV's
#: assertion, exit 1).
MAX_TEXTURE_TEXELS = 1 << 26
#: Host bytes per pixel while a texture is read and packed (measured peak RSS: 4096^2 adds ~410 MB,
#: 2048^2 ~75 MB; the decoded float64 copy, the uint32 texels and the buffer upload), rounded up.
TEXTURE_BYTES_PER_TEXEL = 40
#: The same for a float texture (EXR / HDR / 16-bit; measured: a 2048^2 EXR or 16-bit PNG adds
#: ~210 MB, 53 bytes a pixel: the decoder's planes, the float32 values, the float64 copy, the
#: 16-byte texels and the packed buffer), rounded up.
FLOAT_TEXTURE_BYTES_PER_TEXEL = 64


def check_texture_size(path: Path, size: tuple[int, int] | None = None) -> None:
    """Refuse, from the header alone (or the decoded ``size``), an image too large for the
    textures buffer or this machine."""
    from ..gpu.host_memory import available_bytes
    from .float_texture import is_float_file
    from .image_header import image_size

    if size is None:
        try:
            size = image_size(path, TextureError)
        except OSError:
            return  # missing or unreadable: the reader below says so
    if size is None:
        return
    w, h = size
    if w * h > MAX_TEXTURE_TEXELS:
        raise TextureError(f"{path}: {w} x {h} = {w * h} pixels; a texture may have at most "
                           f"{MAX_TEXTURE_TEXELS} (2^26, e.g. 8192 x 8192)")
    per = FLOAT_TEXTURE_BYTES_PER_TEXEL if is_float_file(path) else TEXTURE_BYTES_PER_TEXEL
    need, avail = w * h * per, available_bytes()
    if avail is not None and need > avail:
        raise TextureError(f"{path}: {w} x {h} needs about {need / 2**30:.1f} GiB to load, more than the "
                           f"{avail / 2**30:.1f} GiB of memory available")


def load_texture(path: Path, wrap: str = "repeat", filter: str = "bilinear", uv=IDENTITY_UV,
                 linear: bool = False, alpha: bool = False) -> Texture:
    """An image file as a texture: 8-bit images kept sRGB-encoded (``linear``: read c / 255),
    EXR / HDR / 16-bit images as float values (mcpt/shading/float_texture.py); ``alpha``: the
    alpha channel as grey (linear)."""
    from .float_texture import FLOAT_SUFFIXES, from_16bit, read_float_file

    path = Path(path)
    uv = tuple(map(tuple, uv))
    check_texture_size(path)
    if path.suffix.lower() in FLOAT_SUFFIXES:  # issue #22: linear float values
        values = read_float_file(path, alpha, TextureError)
        return Texture(path, wrap, filter, None, uv, linear, np.ascontiguousarray(values[::-1]))
    from .image_header import png_grey_channels

    raw = _read_cv2(path)
    # OpenCV expands grey + alpha to BGRA: the PNG header tells (issue #21 item 1)
    channels = png_grey_channels(path) or (1 if raw.ndim == 2 else int(raw.shape[2]))
    img = _channels(raw, alpha)
    del raw
    if img.shape[0] < 1 or img.shape[1] < 1:
        raise TextureError(f"{path}: empty image")
    if img.dtype == np.uint16:  # issue #22: all 16 bits, as float values (Mitsuba: sRGB-encoded)
        check_texture_size(path, (img.shape[1], img.shape[0]))
        values = from_16bit(img[::-1], linear or alpha)
        return Texture(path, wrap, filter, None, uv, linear, np.ascontiguousarray(values), channels)
    return Texture(path, wrap, filter, np.ascontiguousarray(img[::-1]), uv, linear, channels=channels)


def _read_cv2(path: Path) -> np.ndarray:
    import cv2  # only scenes with textures pay for the import

    try:
        img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:  # OpenCV's own limits (CV_IO_MAX_IMAGE_PIXELS) past ours: its first line
        raise TextureError(f"{path}: cannot read the image ({str(exc).strip().splitlines()[-1]})") from None
    if img is None:
        raise TextureError(f"{path}: cannot read the image (missing, or not a format OpenCV reads)")
    if img.dtype not in (np.uint8, np.uint16):
        raise TextureError(f"{path}: {img.dtype} pixels; an image texture must be 8- or 16-bit, "
                           "or an .exr / .hdr file")
    return img


def _channels(img: np.ndarray, alpha: bool) -> np.ndarray:
    """(H, W, 3) RGB of an OpenCV image (grey repeated, BGR reversed); ``alpha``: its alpha
    channel as grey (the format's maximum where it has none)."""
    if alpha:  # the alpha channel as grey (opacity); opaque where the image has none
        has = img.ndim == 3 and img.shape[2] in (2, 4)
        a = img[:, :, -1] if has else np.full(img.shape[:2], np.iinfo(img.dtype).max, img.dtype)
        return np.repeat(a[:, :, None], 3, axis=2)
    if img.ndim == 2:
        return np.repeat(img[:, :, None], 3, axis=2)
    if img.shape[2] == 1:
        return np.repeat(img, 3, axis=2)
    if img.shape[2] == 2:  # grey + alpha
        return np.repeat(img[:, :, :1], 3, axis=2)
    return img[:, :, 2::-1]  # BGR(A) -> RGB


def srgb_to_linear(c) -> np.ndarray:
    """The sRGB decoding curve (IEC 61966-2-1) for 8-bit values, in float64."""
    c = np.asarray(c, np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def pack_textures(textures: list) -> np.ndarray:
    """The ``textures`` buffer: headers, then each texture's data texels (``texels()``): an
    image's pixels, 4 per RGBA32UI texel, or a checkerboard's colours."""
    n = len(textures)
    chunks, headers = [], np.zeros((max(n, 1), 4), np.uint32)
    offset = n
    for j, t in enumerate(textures):
        data = t.texels()
        headers[j] = (offset, t.width, t.height, t.flags)
        chunks.append(data)
        offset += data.shape[0]
    return np.concatenate([headers[:max(n, 1)]] + chunks) if chunks else headers


def _wrap_index(i: np.ndarray, n: int, wrap: str) -> np.ndarray:
    if wrap == "repeat":
        return np.mod(i, n)
    if wrap == "clamp":
        return np.clip(i, 0, n - 1)
    p = np.mod(i, 2 * n)
    return np.where(p < n, p, 2 * n - 1 - p)


def _reduce(u: np.ndarray, wrap: str) -> np.ndarray:
    if wrap == "repeat":
        return u - np.floor(u)
    if wrap == "clamp":
        return np.clip(u, 0.0, 1.0)
    return u - 2.0 * np.floor(u / 2.0)


def lookup(t, uv: np.ndarray) -> np.ndarray:
    """Reference lookup (float64): the linear RGB the shader returns at texture coordinates uv."""
    uv = apply_uv(t.uv, uv)
    if not isinstance(t, Texture):
        return t.lookup(uv)
    lin = t.decoded()
    u, v = _reduce(uv[:, 0], t.wrap), _reduce(uv[:, 1], t.wrap)
    if t.filter == "nearest":
        x = _wrap_index(np.floor(u * t.width).astype(np.int64), t.width, t.wrap)
        y = _wrap_index(np.floor(v * t.height).astype(np.int64), t.height, t.wrap)
        return lin[y, x]
    x, y = u * t.width - 0.5, v * t.height - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    xs = [_wrap_index(x0, t.width, t.wrap), _wrap_index(x0 + 1, t.width, t.wrap)]
    ys = [_wrap_index(y0, t.height, t.wrap), _wrap_index(y0 + 1, t.height, t.wrap)]
    top = lin[ys[1], xs[0]] * (1 - fx) + lin[ys[1], xs[1]] * fx
    bot = lin[ys[0], xs[0]] * (1 - fx) + lin[ys[0], xs[1]] * fx
    return bot * (1 - fy) + top * fy


def pack_uvs(uvs: np.ndarray) -> np.ndarray:
    """Two RGBA32UI texels per triangle: (u0, v0, u1, v1), (u2, v2, 0, 0) as float bits."""
    f = uvs.shape[0]
    out = np.zeros((f, 8), np.float32)
    out[:, :6] = uvs.reshape(f, 6)
    return out.view(np.uint32).reshape(-1, 4)
