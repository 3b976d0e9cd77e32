"""An 8/16-bit image's size from its header, before anything is decoded (a 40000 x 40000 PNG of a
few kilobytes would otherwise allocate gigabytes in the decoder first): PNG's IHDR chunk, JPEG's
start-of-frame segment. Used by surface textures (mcpt/shading/texture.py) and LDR environment
maps (mcpt/shading/envmap_file.py)."""

from __future__ import annotations

import struct
from pathlib import Path

_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def ldr_size(path: Path) -> tuple[int, int] | None:
    """PNG: the IHDR chunk; JPEG: the first start-of-frame segment. None if not found (OpenCV
    then decides)."""
    with open(path, "rb") as f:
        head = f.read(24)
        if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
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
