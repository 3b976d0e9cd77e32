"""Explicit shader assembly and the program cache.

A program is assembled from files under ``glsl/``: ``#version`` first, then the feature preamble
(every define emitted as 0/1 or a number, see :mod:`mcpt.gpu.features`), then the entry file with its
``#include "x.glsl"`` lines expanded in place. Conditionals made only of ``MCPT_*`` defines are
resolved here, so code a scene does not use (and the files it would include) never even reaches
the driver: the source of a diffuse-only scene holds no glass or metal code. Skipped lines become
blank lines, which keeps every line number right. Each file gets a GLSL source-string number and every
chunk is preceded by ``#line N SOURCE``, so a compiler message such as ``3:42(7): error`` can be
translated back to ``bvh.glsl:42``. Compiled programs are cached by (entry files, feature key).

A program of the caller's own (a shader that calls the library's GLSL functions, e.g. to check one
routine in isolation) passes its fragment source as text: :func:`program` ``fragment_text``. Its
``#include`` lines name files of glsl/ and are assembled the same way.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources
from pathlib import Path

from ..errors import McptError

GLSL_VERSION = "#version 430 core"  # layout(binding=N) needs 4.20; 4.30 for std430-era built-ins
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
_DEFINE = re.compile(r"^#define\s+(MCPT_\w+)\s+(-?\d+)\s*$", re.M)
_DIRECTIVE = re.compile(r"^\s*#\s*(if|ifdef|ifndef|elif|else|endif)\b\s*(.*?)\s*(?://.*)?$")
_GUARD = re.compile(r"^[\sA-Z0-9_()!&|<>=]*$")


class ShaderError(McptError, RuntimeError):
    """A shader failed to compile or link; the message names file:line."""


def glsl_dir() -> Path:
    """Where the shaders are: the ``mcpt.glsl`` package (the source tree's glsl/ folder, mapped
    there by pyproject.toml for wheels and editable installs alike)."""
    try:
        here = Path(str(resources.files("mcpt.glsl")))
    except (ModuleNotFoundError, TypeError) as exc:  # pragma: no cover - a broken install
        raise ShaderError(f"GLSL sources not found: {exc}") from None
    if not (here / "pathtrace.frag").is_file():  # pragma: no cover
        raise ShaderError(f"GLSL sources not found in {here}")
    return here


@cache
def _read(name: str) -> str:
    """A shader file of glsl/."""
    path = glsl_dir() / name
    if not path.is_file():
        raise ShaderError(f"shader file {name!r} not found in {glsl_dir()}")
    return path.read_text()


class Source:
    """An assembled GLSL source plus the table that maps source-string numbers to file names.

    ``text``: the entry's own source instead of glsl/``entry`` (``entry`` then only names it in
    compiler messages); its includes still come from glsl/."""

    def __init__(self, entry: str, preamble: str, text: str | None = None):
        self._entry_text = {entry: text} if text is not None else {}
        self.files: list[str] = ["<preamble>"]
        self._seen: set[str] = set()
        self._defines = {k: int(v) for k, v in _DEFINE.findall(preamble)}
        body = self._expand(entry)
        self.text = f"{GLSL_VERSION}\n#line 1 0\n{preamble}\n{body}"

    def _expand(self, name: str) -> str:
        if name in self._seen:  # include guard: each file once
            return ""
        self._seen.add(name)
        self.files.append(name)
        sid = len(self.files) - 1
        out = [f"#line 1 {sid}"]
        # One frame per open #if: known = decided here from the preamble (its directive lines are
        # dropped, only the live branch stays); otherwise the driver decides (lines kept as is).
        frames: list[dict] = []

        def live() -> bool:
            return all(not f["dead"] and (not f["known"] or f["active"]) for f in frames)

        source = self._entry_text[name] if name in self._entry_text else _read(name)
        for lineno, line in enumerate(source.splitlines(), start=1):
            d = _DIRECTIVE.match(line)
            if d:
                out.append(self._directive(d.group(1), d.group(2), frames, live, line, name, lineno))
                continue
            m = _INCLUDE.match(line)
            if not live():
                out.append("")
            elif m:
                out.append(self._expand(m.group(1)))
                out.append(f"#line {lineno + 1} {sid}")
            else:
                out.append(line)
        return "\n".join(out)

    def _directive(self, kind, expr, frames, live, line, name, lineno) -> str:
        if kind in ("if", "ifdef", "ifndef"):
            if not live():
                frames.append({"dead": True, "known": False, "active": False, "taken": False})
                return ""
            if kind == "if":
                value = self._evaluate(expr)
            elif expr.startswith("MCPT_"):
                value = (expr in self._defines) == (kind == "ifdef")
            else:
                value = None
            frames.append({"dead": False, "known": value is not None, "active": bool(value),
                           "taken": bool(value)})
            return "" if value is not None else line
        if not frames:
            raise ShaderError(f"{name}:{lineno}: #{kind} without #if")
        f = frames[-1]
        if kind == "endif":
            frames.pop()
            return line if not f["dead"] and not f["known"] else ""
        if f["dead"]:
            return ""
        if not f["known"]:
            return line
        if kind == "else":
            f["active"], f["taken"] = not f["taken"], True
        else:  # elif
            value = False if f["taken"] else self._evaluate(expr)
            if value is None:
                raise ShaderError(f"{name}:{lineno}: #elif must test MCPT_ defines like its #if")
            f["active"] = value
            f["taken"] = f["taken"] or value
        return ""

    def _evaluate(self, expr: str) -> bool | None:
        """A guard of MCPT_ defines, integers, ! && || == != < > and parentheses, evaluated with
        the preamble's values; None (leave it to the driver) for anything else."""
        if not _GUARD.match(expr):
            return None
        names = set(re.findall(r"[A-Z_][A-Z0-9_]*", expr))
        if not names or not names <= set(self._defines):
            return None
        py = re.sub(r"!(?!=)", " not ", expr.replace("&&", " and ").replace("||", " or "))
        try:
            return bool(eval(py, {"__builtins__": {}}, dict(self._defines)))  # noqa: S307 - names checked
        except Exception:  # malformed guard: let the GLSL compiler report it
            return None

    def translate(self, log: str) -> str:
        """Rewrite ``SID:LINE(COL)`` (Mesa) and ``SID(LINE)`` (NVIDIA) into ``file:LINE``."""

        def name(sid: str) -> str:
            i = int(sid)
            return self.files[i] if 0 <= i < len(self.files) else sid

        log = re.sub(r"\b(\d+):(\d+)\((\d+)\)", lambda m: f"{name(m.group(1))}:{m.group(2)}:{m.group(3)}", log)
        log = re.sub(r"^(\d+)\((\d+)\)", lambda m: f"{name(m.group(1))}:{m.group(2)}", log, flags=re.M)
        return log


_cache: dict = {}


def program(ctx, vertex: str, fragment: str, preamble: str, key, *, fragment_text: str | None = None):
    """Compile (or fetch from the cache) the program for ``key`` on ``ctx`` from the glsl/ files
    ``vertex`` and ``fragment``, or with ``fragment_text`` from that fragment source (a program of
    the caller's; ``fragment`` names it in compiler messages, its includes come from glsl/)."""
    def build():
        vs, fs = Source(vertex, preamble), Source(fragment, preamble, fragment_text)
        return _compiled(lambda: ctx.program(vertex_shader=vs.text, fragment_shader=fs.text),
                         lambda msg: fs if "fragment" in msg.lower() or "GLSL Compiler failed" in msg else vs)
    return _cached((id(ctx), vertex, fragment, key, fragment_text), build)


def compute_program(ctx, entry: str, preamble: str, key):
    """Compile (or fetch from the cache) glsl/``entry`` as a compute shader for ``key`` (the same
    assembly as :func:`program`'s fragment stage; the entry declares its own work group)."""
    def build():
        cs = Source(entry, preamble)
        return _compiled(lambda: ctx.compute_shader(cs.text), lambda msg: cs)
    return _cached((id(ctx), "compute", entry, key, None), build)


def _cached(ck, build):
    if ck not in _cache:
        _cache[ck] = build()
    return _cache[ck]


def _compiled(make, source_of):
    """``make()``, or a ShaderError with the driver's log in file:line terms of ``source_of(log)``."""
    try:
        return make()
    except Exception as exc:  # moderngl.Error carries the driver's log
        msg = str(exc)
        raise ShaderError(source_of(msg).translate(msg).strip()) from None


def clear_cache() -> None:
    _cache.clear()
