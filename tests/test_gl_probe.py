"""An OSMesa context that would crash the process is refused in one line, exit 3 (issue #24 item 18):
``GALLIUM_DRIVER=bogus`` made OSMesaCreateContextAttribs segfault (exit 139, no message)."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys

import pytest

from mcpt.gpu import context

from .conftest import ROOT

HAS_OSMESA = bool(ctypes.util.find_library("OSMesa"))


def render(tmp_path, backend: str, **env) -> subprocess.CompletedProcess:
    out = tmp_path / "x.exr"
    run_env = {k: v for k, v in os.environ.items() if k not in ("MCPT_GL_BACKEND", "EGL_LOG_LEVEL")}
    return subprocess.run([sys.executable, "-m", "mcpt", "render", str(ROOT / "scenes" / "cornell-box.yaml"),
                           "--spp", "1", "--resolution", "8x8", "-o", str(out), "--gl-backend", backend],
                          capture_output=True, text=True, env={**run_env, **env}, timeout=300, cwd=tmp_path)


@pytest.mark.parametrize("backend", ["osmesa", "auto"])
def test_bogus_gallium_driver_is_exit_3_in_one_line(tmp_path, backend):
    r = render(tmp_path, backend, GALLIUM_DRIVER="bogus")
    if backend == "auto" and r.returncode == 0:
        pytest.skip("EGL here ignores GALLIUM_DRIVER (not Mesa's), so auto rendered")
    assert r.returncode == 3, (r.returncode, r.stderr[-2000:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mcpt: error:"), r.stderr
    if HAS_OSMESA:
        assert "OSMesa back end unavailable: creating a context crashed (SIGSEGV)" in lines[0]
        assert "GALLIUM_DRIVER='bogus'" in lines[0]
    assert not (tmp_path / "x.exr").exists()


@pytest.mark.skipif(not HAS_OSMESA, reason="no libOSMesa")
def test_a_driver_mesa_has_passes_the_probe_and_renders():
    code = ("from mcpt.gpu.context import create_context, _probed\n"
            "c = create_context('osmesa'); print(c.backend, len(_probed), list(_probed.values()))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "GALLIUM_DRIVER": "llvmpipe"})
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["osmesa", "1", "[None]"]


def test_probe_runs_once_and_only_with_gallium_driver_set(monkeypatch):
    calls = []
    monkeypatch.setattr(context, "_probed", {})
    monkeypatch.setattr(context, "_run_probe", lambda path, driver: calls.append((path, driver)) or "no good")
    monkeypatch.delenv("GALLIUM_DRIVER", raising=False)
    context._probe_osmesa("libOSMesa.so.8")  # unset: Mesa falls back through its drivers, no probe
    assert calls == []
    monkeypatch.setenv("GALLIUM_DRIVER", "bogus")
    for _ in range(3):
        with pytest.raises(context.GLError, match="no good"):
            context._probe_osmesa("libOSMesa.so.8")
    assert calls == [("libOSMesa.so.8", "bogus")]


def test_a_probe_that_fails_without_a_signal_is_one_line():
    message = context._run_probe("/nonexistent/libOSMesa.so", "llvmpipe")
    assert message == "OSMesa could not create a GL 4.2+ core context (GALLIUM_DRIVER='llvmpipe')"
