"""Writing images without ever leaving a broken file at the user's path.

``.exr``: linear RGB float32 through OpenEXR (ZIP, lossless), with the render's metadata in the
header. ``.png``: exposure, the sRGB transfer curve, 8 bits, through OpenCV (BGR order).
Both are written to a temporary file in the destination folder and renamed over the target
only when complete (rename is atomic within a file system).
"""

from __future__ import annotations

import os
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import McptError

FORMATS = (".exr", ".png")


class ImageError(McptError, ValueError):
    pass


def check_output_path(path: str | Path) -> Path:
    """Fail early, before any rendering, on an output that could not be written: an existing
    folder, an unknown extension, or a folder where no file can be created. A missing folder is
    created (``-o renders/a.exr`` should just work)."""
    p = Path(path)
    if p.is_dir():
        raise ImageError(f"{p}: is an existing folder, not an image file")
    if p.suffix.lower() not in FORMATS:
        raise ImageError(f"{p}: unknown image format {p.suffix or '(none)'!r}; use .exr or .png")
    parent = p.parent if str(p.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        # Permission bits do not tell (root ignores them; read-only mounts): create and remove
        # a temporary file where the image will be written.
        fd, probe = tempfile.mkstemp(prefix=f".{p.name[:200]}.", suffix=".check", dir=parent)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ImageError(f"{p}: cannot write in {parent}: {exc.strerror or exc}") from None
    return p


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 transfer curve on [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_srgb8(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB (exposure in stops), rounded to nearest."""
    v = linear_to_srgb(np.nan_to_num(rgb, nan=0.0, posinf=1.0, neginf=0.0) * (2.0 ** exposure))
    return np.round(v * 255.0).astype(np.uint8)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _atomic(path: Path, write) -> None:
    """Write through a temporary file in the same folder, renamed over ``path`` when complete:
    a failure (disk full, Ctrl-C, a writer error) leaves neither a partial image nor a temporary
    file, and an image already at ``path`` untouched."""
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:200]}.", suffix=path.suffix, dir=folder)
    except OSError as exc:
        raise ImageError(f"{path}: cannot write in {folder}: {exc.strerror or exc}") from None
    os.close(fd)
    try:
        try:
            write(tmp)
            # mkstemp makes the file private (0600); give the image the usual permissions.
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, path)
        except (OSError, RuntimeError) as exc:  # OpenEXR reports I/O failures as RuntimeError
            raise ImageError(f"{path}: cannot write the image: "
                             f"{' '.join((getattr(exc, 'strerror', None) or str(exc)).split())}") from None
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_exr(path: str | Path, rgb: np.ndarray, metadata: dict | None = None,
              layers: dict[str, tuple[np.ndarray, str]] | None = None, alpha: np.ndarray | None = None) -> None:
    """Linear float32 EXR (ZIP). ``layers``: extra channel groups by layer name, each an
    (H, W, len(names)) array and its channel letters, written as ``layer.X`` channels (the
    ``layer.channel`` convention compositors and OIDN tools read), e.g.
    ``{"albedo": (a, "RGB"), "normal": (n, "XYZ"), "depth": (d, "Z")}``. ``alpha`` (H, W): an ``A``
    channel (the RGB is premultiplied by it, EXR's convention: transparent film, issue #20)."""
    import OpenEXR

    p = check_output_path(path)
    channels = {"RGB": np.ascontiguousarray(rgb, dtype=np.float32)}  # OpenEXR rejects float64
    if alpha is not None:
        channels = {"RGBA": np.ascontiguousarray(np.dstack([rgb, alpha]), dtype=np.float32)}
    for layer, (data, names) in (layers or {}).items():
        data = np.asarray(data, np.float32).reshape(*np.shape(rgb)[:2], len(names))
        for i, c in enumerate(names):
            channels[f"{layer}.{c}"] = np.ascontiguousarray(data[..., i])
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for k, v in (metadata or {}).items():
        # Ints > 2^31 and floats needing double precision would be mangled: store them as text.
        header[k] = v if isinstance(v, str) else str(v)
    _atomic(p, lambda tmp: OpenEXR.File(dict(header), channels).write(tmp))


EXR_MAGIC = b"\x76\x2f\x31\x01"


def _read(path: str | Path, pick, **kw):
    """``pick(f)`` of the OpenEXR file at ``path``. A file that is not an EXR, or one OpenEXR cannot
    read, is an :class:`ImageError` of one line (issue #24 item 16): OpenEXR prints its own
    reasons from C++ on the process's stdout and stderr, so these are collected during the read
    (both descriptors restored after) and the first of them names what is wrong."""
    import OpenEXR

    with open(path, "rb") as f:  # FileNotFoundError as it is: the caller words it
        magic = f.read(4)
    if magic != EXR_MAGIC:
        kind = " (a PNG)" if magic == b"\x89PNG" else " (empty)" if not magic else ""
        raise ImageError(f"{path}: not an EXR file{kind}")
    with tempfile.TemporaryFile() as sink:
        try:
            with _collected(sink):
                with OpenEXR.File(str(path), **kw) as f:
                    return pick(f)
        except KeyError:  # pick's: a channel the caller needs is missing (its error to word)
            raise
        except Exception as exc:  # noqa: BLE001 - OpenEXR raises varied types on damaged files
            sink.seek(0)
            said = [line for line in sink.read().decode(errors="replace").splitlines() if line.strip()]
            reason = said[0].removeprefix(f"{path}: ") if said else str(exc)
            raise ImageError(f"{path}: not a readable EXR ({' '.join(reason.split())})") from None


@contextmanager
def _collected(sink):
    """File descriptors 1 and 2 (what C and C++ code prints) written to ``sink`` inside the block,
    restored after; one that is not open is left alone."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = {}
    try:
        for fd in (1, 2):
            try:
                saved[fd] = os.dup(fd)
            except OSError:
                continue
            os.dup2(sink.fileno(), fd)
        yield
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)


def read_exr(path: str | Path) -> tuple[np.ndarray, dict]:
    def pick(f):
        ch = f.channels()
        if "RGB" not in ch and "RGBA" in ch:  # a transparent film's image: its colour
            return np.array(ch["RGBA"].pixels[..., :3], np.float32), dict(f.header())
        return np.array(ch["RGB"].pixels, np.float32), dict(f.header())

    return _read(path, pick)


def read_exr_channels(path: str | Path, with_header: bool = False):
    """Every channel of an EXR by its full name (``R``, ``albedo.G``, ``depth.Z``, ...); with
    ``with_header``, ``(channels, header)``."""

    def pick(f):
        channels = {k: np.array(c.pixels, np.float32) for k, c in f.channels().items()}
        return (channels, dict(f.header())) if with_header else channels

    return _read(path, pick, separate_channels=True)


def write_png(path: str | Path, rgb: np.ndarray, exposure: float = 0.0, alpha: np.ndarray | None = None) -> None:
    """sRGB PNG; with ``alpha`` (H, W) an RGBA one, colour un-premultiplied (PNG's convention)."""
    import cv2

    p = check_output_path(path)
    if alpha is None:
        bgr = to_srgb8(rgb, exposure)[..., ::-1]
    else:
        a = np.clip(np.asarray(alpha, np.float64), 0.0, 1.0)[..., None]
        straight = np.where(a > 0, np.asarray(rgb, np.float64) / np.maximum(a, 1e-12), 0.0)
        a8 = np.round(a * 255.0).astype(np.uint8)
        bgr = np.concatenate([to_srgb8(straight, exposure)[..., ::-1], a8], axis=-1)

    ok, data = cv2.imencode(".png", np.ascontiguousarray(bgr))
    if not ok:  # pragma: no cover - encoding an 8-bit array in memory does not fail
        raise ImageError(f"{p}: OpenCV could not encode the PNG")

    # Written by Python, not by OpenCV's file writer, so a full disk is one OSError (one error
    # line), not a libpng warning on stderr followed by a failure.
    _atomic(p, lambda tmp: _write_bytes(tmp, data.tobytes()))


def _write_bytes(path: str, data: bytes) -> None:
    with open(path, "wb") as f:
        f.write(data)


def write_image(path: str | Path, rgb: np.ndarray, metadata: dict | None = None,
                exposure: float = 0.0, layers: dict | None = None, alpha: np.ndarray | None = None) -> None:
    """EXR (with ``layers``, see :func:`write_exr`) or sRGB PNG (the beauty only) by extension;
    ``alpha``: the transparent film's coverage, written as A / the PNG's alpha."""
    extra = {} if alpha is None else {"alpha": alpha}  # (opaque renders call as before)
    if Path(path).suffix.lower() == ".exr":
        write_exr(path, rgb, metadata, layers, **extra)
    else:
        write_png(path, rgb, exposure, **extra)


def write_images(paths, rgb: np.ndarray, metadata: dict | None = None, exposure: float = 0.0,
                 layers: dict | None = None, alpha: np.ndarray | None = None) -> list:
    """Every output of one render or merge, one after the other. A stop signal during the writes
    (signals.Interrupted) leaves the file being written as it was; the exception then records
    which outputs hold the new image and which the old (issue #24: the message named no file)."""
    done: list = []
    try:
        for path in paths:
            write_image(path, rgb, metadata, exposure, layers=layers, alpha=alpha)
            done.append(str(path))
    except BaseException as exc:
        if hasattr(exc, "signum"):  # signals.Interrupted (output/ does not import farm/)
            exc.written, exc.kept = done, [str(p) for p in paths if str(p) not in done]
        raise
    return done

