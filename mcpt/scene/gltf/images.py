"""glTF textures as image files for mcpt's texture loader (mcpt/shading/texture.py).

mcpt reads textures from files (OpenCV). A glTF image is a file beside the glTF (``uri``), or
embedded: a ``data:`` URI or a bufferView of a .glb. Embedded images are written once to
:func:`cache_dir` under a name made of the SHA-256 of their bytes (so the same image is written
once, whatever file embeds it, and a changed image never reads a stale copy); the write is
atomic (temporary file, then rename). The texture's ``sampler`` gives wrap (glTF wrapS; wrapT is
assumed equal, with a warning otherwise) and filter (magFilter NEAREST -> nearest, else bilinear).
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
from pathlib import Path
from urllib.parse import unquote

from .container import Gltf, decode_data_uri, obj

log = logging.getLogger("mcpt")

#: glTF sampler wrap codes -> mcpt wrap modes.
WRAPS = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
NEAREST = 9728
#: Image MIME types mcpt's loader reads, and the suffix their cached copy gets.
MIME_SUFFIX = {"image/png": ".png", "image/jpeg": ".jpg"}


def cache_dir() -> Path:
    """Where embedded images are written: $MCPT_CACHE_DIR, else $XDG_CACHE_HOME/mcpt, else
    ~/.cache/mcpt; then ``gltf-images``."""
    base = os.environ.get("MCPT_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "mcpt")
    return Path(base) / "gltf-images"


def _cached_copy(data: bytes, suffix: str) -> Path:
    """The cache file holding ``data`` (written the first time)."""
    folder = cache_dir()
    path = folder / (hashlib.sha256(data).hexdigest()[:32] + suffix)
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".part")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return path


def _suffix(g: Gltf, where: str, mime) -> str:
    if mime not in MIME_SUFFIX:
        raise g.error(where, f"mimeType {mime!r}: mcpt reads {', '.join(MIME_SUFFIX)} images")
    return MIME_SUFFIX[mime]


def image_file(g: Gltf, index: int, where: str) -> Path:
    """A file holding image ``index``: the glTF's own file, or a cached copy of an embedded one."""
    img = g.get("images", index, where)
    at = f"images[{index}]"
    uri = img.get("uri")
    if isinstance(uri, str) and uri.startswith("data:"):
        mime = uri[5:].partition(";")[0]
        return _cached_copy(decode_data_uri(g, uri, at), _suffix(g, at, mime))
    if isinstance(uri, str):
        path = (g.path.parent / unquote(uri)).resolve()
        if not path.is_file():
            raise g.error(at, f"image file not found: {path}")
        return path
    if "bufferView" in img:
        vi = img["bufferView"]
        view = g.get("bufferViews", vi, at)
        start, length = view.get("byteOffset", 0), view.get("byteLength", 0)
        buf = g.buffer(view.get("buffer"))
        if not (isinstance(start, int) and isinstance(length, int) and 0 <= start and start + length <= len(buf)):
            raise g.error(f"bufferViews[{vi}]", f"bytes {start!r}+{length!r} overrun its buffer")
        return _cached_copy(bytes(buf[start:start + length]), _suffix(g, at, img.get("mimeType")))
    raise g.error(at, "neither a uri nor a bufferView")


def texture(g: Gltf, info: dict, where: str) -> dict:
    """The mcpt ImageTexture data (``{file, wrap, filter}``) of a glTF textureInfo ``info``."""
    ti = info.get("index")
    tex = g.get("textures", ti, where)
    at = f"textures[{ti}]"
    if "source" not in tex:
        exts = ", ".join(obj(tex.get("extensions"))) or "none"
        raise g.error(at, f"no source image mcpt can read (extensions: {exts}; PNG and JPEG only)")
    wrap, filt = "repeat", "bilinear"
    if "sampler" in tex:
        s = g.get("samplers", tex["sampler"], at)
        wrap_s, wrap_t = s.get("wrapS", 10497), s.get("wrapT", 10497)
        if wrap_s not in WRAPS or wrap_t not in WRAPS:
            raise g.error(f"samplers[{tex['sampler']}]", f"wrap modes {wrap_s!r}/{wrap_t!r} are not glTF's")
        if wrap_s != wrap_t:
            log.warning("%s: samplers[%d]: wrapS %s and wrapT %s differ; mcpt wraps both as %s",
                        g.path, tex["sampler"], WRAPS[wrap_s], WRAPS[wrap_t], WRAPS[wrap_s])
        wrap = WRAPS[wrap_s]
        filt = "nearest" if s.get("magFilter") == NEAREST else "bilinear"
    return {"file": str(image_file(g, tex["source"], at)), "wrap": wrap, "filter": filt}
