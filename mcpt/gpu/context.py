"""The one module that owns the OpenGL context.

Two headless back ends, both checked on Mesa llvmpipe and usable unchanged on a real GPU:

* ``egl``    -- ``moderngl.create_standalone_context(backend="egl")``; function pointers through
               ``eglGetProcAddress``.
* ``osmesa`` -- Mesa's off-screen renderer through ctypes: ``OSMesaCreateContextAttribs`` with a core
               profile, ``OSMesaMakeCurrent`` on a tiny buffer (we render into our own FBOs), then
               ``moderngl.init_context(loader=...)`` with ``OSMesaGetProcAddress``.

``auto`` tries EGL, then OSMesa. The choice comes from the argument, else ``MCPT_GL_BACKEND``.

moderngl has no buffer-texture type, so :class:`GLContext` also hands out the raw GL entry points
that :mod:`mcpt.tbo` needs (``glTexBuffer`` and friends), resolved through the same loader that
created the context so they belong to it.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field

import moderngl

from ..errors import McptError

BACKENDS = ("auto", "egl", "osmesa")

# GL enums used by the raw calls below (from the GL 4.5 core headers).
GL_TEXTURE_BUFFER = 0x8C2A
GL_TEXTURE0 = 0x84C0
GL_MAX_TEXTURE_BUFFER_SIZE = 0x8C2B
GL_MAX_TEXTURE_SIZE = 0x0D33
GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS = 0x8B4D
GL_MAX_VIEWPORT_DIMS = 0x0D3A


class GLError(McptError, RuntimeError):
    """A GL back end is missing or failed; the message is one line meant for the user."""


@dataclass
class GLContext:
    """A current GL context plus the raw functions moderngl does not expose."""

    ctx: moderngl.Context
    backend: str
    _proc: object  # callable name -> address
    _keepalive: list = field(default_factory=list)
    _fns: dict = field(default_factory=dict)

    # ---- raw entry points -------------------------------------------------------------------
    def fn(self, name: str, restype, *argtypes):
        """A ctypes function for GL entry point ``name`` (cached)."""
        key = name
        if key not in self._fns:
            addr = self._proc(name)
            if not addr:
                raise GLError(f"GL function {name} is not available on the {self.backend} back end")
            self._fns[key] = ctypes.CFUNCTYPE(restype, *argtypes)(addr)
        return self._fns[key]

    def get_integer(self, pname: int, count: int = 1) -> int | tuple[int, ...]:
        arr = (ctypes.c_int * max(count, 4))()
        self.fn("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(pname, arr)
        return arr[0] if count == 1 else tuple(arr[:count])

    # ---- facts for metadata and limits ---------------------------------------------------------
    @property
    def renderer(self) -> str:
        return self.ctx.info["GL_RENDERER"]

    @property
    def version(self) -> str:
        return self.ctx.info["GL_VERSION"]

    def limits(self) -> dict:
        """The GL limits that mcpt checks its uploads against."""
        return {
            "max_texture_buffer_size": int(self.get_integer(GL_MAX_TEXTURE_BUFFER_SIZE)),
            "max_texture_size": int(self.get_integer(GL_MAX_TEXTURE_SIZE)),
            "max_texture_units": int(self.get_integer(GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS)),
            "max_viewport_dims": list(self.get_integer(GL_MAX_VIEWPORT_DIMS, 2)),
        }

    def describe(self) -> dict:
        return {"backend": self.backend, "renderer": self.renderer, "version": self.version}

    def release(self) -> None:
        try:
            self.ctx.release()
        except Exception:  # pragma: no cover - best effort at shutdown
            pass


def _egl() -> GLContext:
    # Mesa's libEGL prints its own lines on stderr ("libEGL warning: egl: failed to create dri2
    # screen") before eglInitialize fails; the GLError below says it in one line (issue #24 item 18).
    # -vv (debug logging) keeps them, as does an EGL_LOG_LEVEL the user sets.
    if not logging.getLogger("mcpt").isEnabledFor(logging.DEBUG):
        os.environ.setdefault("EGL_LOG_LEVEL", "fatal")
    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=420)
    except Exception as exc:  # glcontext raises plain Exceptions with varied texts
        raise GLError(f"EGL back end unavailable ({exc}); install libegl1 libegl-mesa0 libgl1-mesa-dri "
                      "or use --gl-backend osmesa") from None
    lib = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    gpa = lib.eglGetProcAddress
    gpa.restype = ctypes.c_void_p
    gpa.argtypes = [ctypes.c_char_p]
    return GLContext(ctx, "egl", lambda name: gpa(name.encode()), [lib])


# OSMesa attribute enums (GL/osmesa.h).
_OSMESA_FORMAT, _OSMESA_RGBA = 0x22, 0x1908
_OSMESA_PROFILE, _OSMESA_CORE_PROFILE = 0x33, 0x34
_OSMESA_MAJOR, _OSMESA_MINOR = 0x36, 0x37
_GL_UNSIGNED_BYTE = 0x1401


#: What a probe process runs (stdlib only: `python -I -S` starts fast): create and make current the
#: context _osmesa creates. Exit 1: no GL 4.2+ core context; killed by a signal: Mesa crashed.
_PROBE = """
import ctypes, sys
lib = ctypes.CDLL(sys.argv[1])
lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int]
for major, minor in ((4, 5), (4, 3), (4, 2)):
    handle = lib.OSMesaCreateContextAttribs((ctypes.c_int * 11)(%d, %d, %d, %d, %d, major, %d, minor, 0, 0, 0), None)
    if handle:
        sys.exit(0 if lib.OSMesaMakeCurrent(handle, (ctypes.c_ubyte * 64)(), %d, 4, 4) else 1)
sys.exit(1)
"""
_probed: dict[tuple, str | None] = {}


def _probe_osmesa(path: str) -> None:
    """Raise GLError if creating the OSMesa context would kill this process (issue #24 item 18).

    With GALLIUM_DRIVER naming a driver that this Mesa lacks (``bogus``), OSMesaCreateContextAttribs
    dereferences the NULL screen and the process dies of SIGSEGV (exit 139, no message) where the
    README promises exit 3. A crash cannot be caught in-process, so a short-lived child process
    (sys.executable, exec'd: no fork of a process holding a context) tries first, once per process
    and setting. Mesa's sw_screen_create (gallium/auxiliary/target-helpers/inline_sw_helper.h) stops
    at GALLIUM_DRIVER when it is set and otherwise tries every software driver built in (llvmpipe,
    softpipe) until one works, so the NULL screen needs GALLIUM_DRIVER set (or a Mesa none of whose
    drivers works): the probe runs only then, and its 35-41 ms (llvmpipe, 2 loaded cores; the
    context itself takes ~24 ms) are not spent on every run."""
    driver = os.environ.get("GALLIUM_DRIVER")
    if not driver or not sys.executable:
        return
    key = (path, driver)
    if key not in _probed:
        _probed[key] = _run_probe(path, driver)
    if _probed[key]:
        raise GLError(_probed[key])


def _run_probe(path: str, driver: str) -> str | None:
    """None if a child process creates the OSMesa context, else why not (one line)."""
    code = _PROBE % (_OSMESA_FORMAT, _OSMESA_RGBA, _OSMESA_PROFILE, _OSMESA_CORE_PROFILE, _OSMESA_MAJOR,
                     _OSMESA_MINOR, _GL_UNSIGNED_BYTE)
    try:
        r = subprocess.run([sys.executable, "-I", "-S", "-c", code, path], stdin=subprocess.DEVNULL,
                           capture_output=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"OSMesa back end unavailable: the probe process failed ({exc})"
    if r.returncode < 0:
        try:
            name = signal.Signals(-r.returncode).name
        except ValueError:
            name = f"signal {-r.returncode}"
        return (f"OSMesa back end unavailable: creating a context crashed ({name}) with "
                f"GALLIUM_DRIVER={driver!r}; unset it or name a driver this Mesa has (llvmpipe)")
    if r.returncode != 0:
        return f"OSMesa could not create a GL 4.2+ core context (GALLIUM_DRIVER={driver!r})"
    return None


def _osmesa() -> GLContext:
    lib = path = None
    for name in ("OSMesa", "libOSMesa.so.8", "libOSMesa.so.6"):
        path = ctypes.util.find_library(name) if "." not in name else name
        if not path:
            continue
        try:
            lib = ctypes.CDLL(path)
            break
        except OSError:
            continue
    if lib is None:
        raise GLError("OSMesa back end unavailable: libOSMesa not found (apt-get install libosmesa6)")
    _probe_osmesa(path)
    lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
    lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
    lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int,
                                      ctypes.c_int]
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
    handle = None
    for major, minor in ((4, 5), (4, 3), (4, 2)):  # layout(binding=N) needs GLSL 4.20
        attrs = (ctypes.c_int * 11)(_OSMESA_FORMAT, _OSMESA_RGBA, _OSMESA_PROFILE, _OSMESA_CORE_PROFILE,
                                    _OSMESA_MAJOR, major, _OSMESA_MINOR, minor, 0, 0, 0)
        handle = lib.OSMesaCreateContextAttribs(attrs, None)
        if handle:
            break
    if not handle:
        raise GLError("OSMesa could not create a GL 4.2+ core context")
    # We never draw into this buffer (all rendering goes to our own FBOs) but OSMesa needs one.
    backing = (ctypes.c_ubyte * (4 * 4 * 4))()
    if not lib.OSMesaMakeCurrent(handle, backing, _GL_UNSIGNED_BYTE, 4, 4):
        raise GLError("OSMesaMakeCurrent failed")

    class _Loader:
        def load_opengl_function(self, name):
            return lib.OSMesaGetProcAddress(name.encode()) or 0

        def release(self):
            lib.OSMesaDestroyContext(handle)

    moderngl.init_context(loader=_Loader())  # returns None; the context becomes moderngl's default
    ctx = moderngl.get_context()
    return GLContext(ctx, "osmesa", lambda name: lib.OSMesaGetProcAddress(name.encode()),
                     [lib, backing])


def create_context(backend: str | None = None) -> GLContext:
    """Create the GL context for ``backend`` (``auto``/``egl``/``osmesa``; None reads MCPT_GL_BACKEND)."""
    backend = (backend or os.environ.get("MCPT_GL_BACKEND") or "auto").lower()
    if backend not in BACKENDS:
        raise GLError(f"unknown GL back end {backend!r}; choose one of {', '.join(BACKENDS)}")
    if backend == "egl":
        return _egl()
    if backend == "osmesa":
        return _osmesa()
    errors = []
    for make in (_egl, _osmesa):
        try:
            return make()
        except GLError as exc:
            errors.append(str(exc))
    raise GLError("no GL back end works: " + "; ".join(errors))


_shared: dict[str, GLContext] = {}


def shared_context(backend: str | None = None) -> GLContext:
    """One context per back end per process, created on first use: creating one costs ~50 ms and
    compiled programs are cached on it (mcpt/gpu/shader.py)."""
    key = (backend or os.environ.get("MCPT_GL_BACKEND") or "auto").lower()
    if key not in _shared:
        _shared[key] = create_context(key)
    return _shared[key]
