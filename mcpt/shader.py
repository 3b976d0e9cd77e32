"""Explicit shader assembly and the program cache.

A program is assembled from files under ``glsl/``: ``#version`` first, then the feature preamble
(every define emitted as 0/1 or a number, see :mod:`mcpt.features`), then the entry file with its
``#include "x.glsl"`` lines expanded in place. Each file gets a GLSL source-string number and every
chunk is preceded by ``#line N SOURCE``, so a compiler message such as ``3:42(7): error`` can be
translated back to ``bvh.glsl:42``. Compiled programs are cached by (entry files, feature key).
"""

from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources
from pathlib import Path

GLSL_VERSION = "#version 430 core"  # layout(binding=N) needs 4.20; 4.30 for std430-era built-ins
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')


class ShaderError(RuntimeError):
    """A shader failed to compile or link; the message names file:line."""


def glsl_dir() -> Path:
    """Where the shaders are: inside the installed package (wheel) or at the source tree's top."""
    try:
        packaged = resources.files("mcpt") / "glsl"
        if packaged.is_dir():
            return Path(str(packaged))
    except (ModuleNotFoundError, TypeError):  # pragma: no cover
        pass
    here = Path(__file__).resolve().parent.parent / "glsl"
    if here.is_dir():
        return here
    raise ShaderError(f"GLSL sources not found (looked in the mcpt package and {here})")


@lru_cache(maxsize=None)
def _read(name: str) -> str:
    return (glsl_dir() / name).read_text()


class Source:
    """An assembled GLSL source plus the table that maps source-string numbers to file names."""

    def __init__(self, entry: str, preamble: str):
        self.files: list[str] = ["<preamble>"]
        self._seen: set[str] = set()
        body = self._expand(entry)
        self.text = f"{GLSL_VERSION}\n#line 1 0\n{preamble}\n{body}"

    def _expand(self, name: str) -> str:
        if name in self._seen:  # include guard: each file once
            return ""
        self._seen.add(name)
        self.files.append(name)
        sid = len(self.files) - 1
        out = [f"#line 1 {sid}"]
        for lineno, line in enumerate(_read(name).splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                out.append(self._expand(m.group(1)))
                out.append(f"#line {lineno + 1} {sid}")
            else:
                out.append(line)
        return "\n".join(out)

    def translate(self, log: str) -> str:
        """Rewrite ``SID:LINE(COL)`` (Mesa) and ``SID(LINE)`` (NVIDIA) into ``file:LINE``."""

        def name(sid: str) -> str:
            i = int(sid)
            return self.files[i] if 0 <= i < len(self.files) else sid

        log = re.sub(r"\b(\d+):(\d+)\((\d+)\)", lambda m: f"{name(m.group(1))}:{m.group(2)}:{m.group(3)}", log)
        log = re.sub(r"^(\d+)\((\d+)\)", lambda m: f"{name(m.group(1))}:{m.group(2)}", log, flags=re.M)
        return log


_cache: dict = {}


def program(ctx, vertex: str, fragment: str, preamble: str, key):
    """Compile (or fetch from the cache) the program for ``key`` on ``ctx``."""
    ck = (id(ctx), vertex, fragment, key)
    if ck in _cache:
        return _cache[ck]
    vs, fs = Source(vertex, preamble), Source(fragment, preamble)
    try:
        prog = ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
    except Exception as exc:  # moderngl.Error carries the driver's log
        msg = str(exc)
        which = fs if "fragment" in msg.lower() or "GLSL Compiler failed" in msg else vs
        raise ShaderError(which.translate(msg).strip()) from None
    _cache[ck] = prog
    return prog


def clear_cache() -> None:
    _cache.clear()
