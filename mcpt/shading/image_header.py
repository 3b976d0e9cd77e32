"""An image's size from its header, before anything is decoded (a 40000 x 40000 PNG of a few
kilobytes would otherwise allocate gigabytes in the decoder first): PNG's IHDR chunk, JPEG's
start-of-frame segment, OpenEXR's dataWindow, Radiance RGBE's resolution line. Used by surface
textures (mcpt/shading/texture.py) and environment maps (mcpt/shading/envmap_file.py)."""

from __future__ import annotations

import re
import struct
from pathlib import Path

_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def ldr_size(path: Path) -> tuple[int, int] | None:
    """PNG: the IHDR chunk; JPEG: the first start-of-frame segment. None if not found (OpenCV
    then decides)."""
    with open(path, "rb") as f:
        head = f.read(24)
        if head[:8] == _PNG_SIGNATURE and head[12:16] == b"IHDR":
            return struct.unpack(">II", head[16:24])
        if head[:2] != b"\xff\xd8":
            return None
        f.seek(2)
        for _ in range(1000):  # segments before the frame header: APPn, DQT, COM, ...
            marker = f.read(4)
            if len(marker) < 4 or marker[0] != 0xFF:
                return None
            length = struct.unpack(">H", marker[2:4])[0]
            if marker[1] in _JPEG_SOF:
                frame = f.read(5)
                if len(frame) < 5:
                    return None
                h, w = struct.unpack(">HH", frame[1:5])
                return w, h
            f.seek(length - 2, 1)
    return None


#: PNG colour types (IHDR byte 25) of grey images, and their channel counts.
_PNG_GREY_CHANNELS = {0: 1, 4: 2}


def png_grey_channels(path: Path) -> int | None:
    """1 or 2 for a grey or grey + alpha PNG (OpenCV expands grey + alpha to BGRA, so the decoded
    image alone does not tell: issue #21 item 1); None for any other file."""
    with open(path, "rb") as f:
        head = f.read(26)
    if len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        return _PNG_GREY_CHANNELS.get(head[25])
    return None


def png_bit_depth(path: Path) -> int | None:
    """A PNG's bits per channel from its IHDR chunk (1, 2, 4, 8 or 16); None for another file."""
    with open(path, "rb") as f:
        head = f.read(25)
    if len(head) == 25 and head[:8] == _PNG_SIGNATURE and head[12:16] == b"IHDR":
        return head[24]
    return None


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def exr_size(path: Path, error: type[Exception] = ValueError) -> tuple[int, int]:
    """An OpenEXR image's (width, height) from its dataWindow; ``error`` names the file if it is
    no EXR."""
    import OpenEXR

    try:
        header = OpenEXR.File(str(path), header_only=True).header()
    except (RuntimeError, OSError, ValueError) as exc:
        raise error(f"{path}: not an OpenEXR image, or unreadable ({_one_line(exc)})") from None
    lo, hi = header["dataWindow"]
    return int(hi[0]) - int(lo[0]) + 1, int(hi[1]) - int(lo[1]) + 1


_HDR_RES = re.compile(rb"^([-+])([XY])\s+(\d+)\s+([-+])([XY])\s+(\d+)\s*$")


def hdr_size(path: Path, error: type[Exception] = ValueError) -> tuple[int, int]:
    """Radiance RGBE: ``#?RADIANCE`` (or ``#?RGBE``), header lines, a blank line, then the
    resolution line, e.g. ``-Y 1024 +X 2048`` (rows first)."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    lines = head.split(b"\n")
    if not lines[0].startswith((b"#?RADIANCE", b"#?RGBE")):
        raise error(f"{path}: not a Radiance .hdr image (no #?RADIANCE signature)")
    try:
        blank = lines.index(b"", 1)
        m = _HDR_RES.match(lines[blank + 1])
    except (ValueError, IndexError):
        m = None
    if m is None:
        raise error(f"{path}: not a Radiance .hdr image (no resolution line in its header)")
    first, second = int(m.group(3)), int(m.group(6))
    return (second, first) if m.group(2) == b"Y" else (first, second)


def image_size(path: Path, error: type[Exception] = ValueError) -> tuple[int, int] | None:
    """(width, height) of an EXR, HDR, PNG or JPEG file from its header; None where the format
    has no reader here (OpenCV then decides)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".exr":
        return exr_size(path, error)
    if suffix == ".hdr":
        return hdr_size(path, error)
    return ldr_size(path)
