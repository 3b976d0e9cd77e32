"""Video (issue #26): frames of a sequence encoded to H.264 MP4 with the FFmpeg binary that the
imageio-ffmpeg package ships (``pip install 'mcpt[video]'``).

Frames are tone-mapped exactly as the PNG output is (mcpt/output/image.py ``to_srgb8``: exposure in
stops, sRGB curve, 8 bits); PNG frames are taken as they are. H.264's 4:2:0 chroma needs even
sizes: an odd width or height is padded by repeating the last column / row (no rescaling). The
file is written under a temporary name in its folder and renamed into place when complete.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import numpy as np

from ..errors import McptError
from .image import check_output_path, read_exr, to_srgb8

VIDEO_SUFFIXES = (".mp4",)


class VideoError(McptError, ValueError):
    """No FFmpeg, no frames, frames of different sizes, a video that cannot be written."""


def is_video(path) -> bool:
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def require_ffmpeg():
    """The imageio_ffmpeg module, or one line saying what to install."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise VideoError("video output needs FFmpeg: pip install 'mcpt[video]' "
                         "(imageio-ffmpeg, which ships the binary)") from None
    return imageio_ffmpeg


def check_video_path(path) -> Path:
    """Fail before any work on a video that could not be written (folder, extension)."""
    p = Path(path)
    if not is_video(p):
        raise VideoError(f"{p}: unknown video format {p.suffix or '(none)'!r}; use .mp4")
    check_output_path(p.with_suffix(".png"))  # the folder exists (made) and takes a file
    if p.is_dir():
        raise VideoError(f"{p}: is an existing folder, not a video file")
    return p


def pattern_files(pattern) -> list:
    """The frames a ``#`` pattern names on disk (``shot.####.png``: shot.0001.png, ...), in frame
    order."""
    p = Path(pattern)
    runs = list(re.finditer(r"#+", p.name))
    if not runs:
        raise VideoError(f"{pattern}: a frame pattern needs '#' for the frame number")
    r = runs[-1]
    head, tail = re.escape(p.name[:r.start()]), re.escape(p.name[r.end():])
    rx = re.compile(f"{head}(\\d{{{r.end() - r.start()},}}){tail}")
    folder = p.parent if str(p.parent) else Path(".")
    found = sorted((int(m.group(1)), folder / n) for n in (os.listdir(folder) if folder.is_dir() else [])
                   if (m := rx.fullmatch(n)))
    if not found:
        raise VideoError(f"{pattern}: no frames found")
    return [f for _, f in found]


def frame_rgb8(path, exposure: float = 0.0) -> np.ndarray:
    """An (H, W, 3) uint8 frame: a PNG as it is, an EXR tone-mapped as the PNG output."""
    path = Path(path)
    if path.suffix.lower() == ".exr":
        return to_srgb8(read_exr(path)[0], exposure)
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise VideoError(f"{path}: cannot read the frame")
    return np.ascontiguousarray(img[..., ::-1])


def _even(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def encode(files, output, fps: float = 24.0, exposure: float = 0.0) -> int:
    """Encode ``files`` (PNG or EXR frames, in order) to ``output``; returns the frame count."""
    ffmpeg = require_ffmpeg()
    out = check_video_path(output)
    files = list(files)
    if not files:
        raise VideoError(f"{out}: no frames to encode")
    first = frame_rgb8(files[0], exposure)
    h, w = _even(first).shape[:2]
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=out.suffix, dir=out.parent)
    os.close(fd)
    writer = None
    try:
        writer = ffmpeg.write_frames(tmp, (w, h), fps=float(fps), codec="libx264", quality=8,
                                     macro_block_size=1, ffmpeg_log_level="error")
        writer.send(None)
        for i, f in enumerate(files):
            img = first if i == 0 else frame_rgb8(f, exposure)
            if img.shape != first.shape:
                raise VideoError(f"{f}: {img.shape[1]}x{img.shape[0]}, the first frame "
                                 f"{first.shape[1]}x{first.shape[0]}: frames must be one size")
            writer.send(np.ascontiguousarray(_even(img)))
        writer.close()
        writer = None
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp's 0600: give the video the usual permissions
        os.replace(tmp, out)
    finally:
        if writer is not None:
            writer.close()
        if os.path.exists(tmp):
            os.unlink(tmp)
    return len(files)
