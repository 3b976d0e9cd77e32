"""Mitsuba 3 as a subprocess: ``../shared/tools/peer_mitsuba.py render`` in its own venv.

Mitsuba is not a dependency of mcpt: it lives in a venv outside the package (``make peer-setup``
creates ``.venv-peer``) and runs as a child process with that venv's python, chosen by
``$MCPT_PEER_PYTHON`` (default ``<root>/.venv-peer/bin/python``). Nothing here imports mitsuba.

Timing is the tool's own: the wall seconds of one ``mi.render`` call plus the copy back to numpy,
which forces evaluation (process start-up, import, scene load and BVH build excluded), and the
process CPU seconds of that call. The image comes back as an EXR so that the error is computed on
our side, with the same function and the same reference as mcpt's.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

from . import scenes

ROOT = Path(__file__).resolve().parent.parent
# Mitsuba's multijitter sampler rounds a sample count up to a product of two near-equal integers
# and says so on stdout (Mitsuba prints its warnings there, not on stderr).
_ROUNDED = re.compile(r"Sample count rounded up to (\d+)")
_ANSI = re.compile(r"\x1b\[[0-9;]*m")  # its warnings are coloured: the JSON may follow a reset code


def tool() -> Path:
    return scenes.shared_dir() / "tools" / "peer_mitsuba.py"


def python() -> Path:
    env = os.environ.get("MCPT_PEER_PYTHON")
    return Path(env) if env else ROOT / ".venv-peer" / "bin" / "python"


@dataclass(frozen=True)
class Availability:
    ok: bool
    reason: str = ""
    version: str = ""


def available(timeout_s: float = 120.0) -> Availability:
    """Whether the peer python exists and imports mitsuba and drjit (one short child process)."""
    py, t = python(), tool()
    if not t.exists():
        return Availability(False, f"{t} not found")
    if not py.exists():
        return Availability(False, f"no python at {py} (run `make peer-setup` or set MCPT_PEER_PYTHON)")
    try:
        out = subprocess.run([str(py), "-c", "import drjit, mitsuba; print(mitsuba.__version__)"],
                             capture_output=True, text=True, timeout=timeout_s)
    except (OSError, subprocess.SubprocessError) as exc:
        return Availability(False, f"{py} failed to start: {exc}")
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        return Availability(False, f"{py} cannot import mitsuba: {last}")
    return Availability(True, version=out.stdout.strip().splitlines()[-1])


class MitsubaError(RuntimeError):
    pass


def parse_output(stdout: str) -> dict:
    """The JSON object the tool prints last, after any warning lines Mitsuba wrote on stdout;
    ``spp_actual`` is the sample count Mitsuba really used (multijitter may round it up)."""
    stdout = _ANSI.sub("", stdout)
    lines = stdout.splitlines()
    start = next((i for i, ln in enumerate(lines) if ln.startswith("{")), None)
    if start is None:
        raise MitsubaError(f"no JSON in peer_mitsuba.py output: {stdout[-500:]!r}")
    res = json.loads("\n".join(lines[start:]))
    rounded = _ROUNDED.findall(stdout)
    res["spp_actual"] = int(rounded[-1]) if rounded else int(res["spp"])
    return res


def render(scene_dir: Path, *, spp: int, seed: int, resolution: int, sampler: str, out_exr: Path,
           variant: str = "llvm_ad_rgb", timeout_s: float = 900.0) -> dict:
    """One timed ``mi.render`` in a fresh process; returns the tool's JSON (see parse_output)."""
    cmd = [str(python()), str(tool()), "render", str(scene_dir), "--variant", variant,
           "--spp", str(spp), "--runs", "1", "--seed", str(seed), "--res", str(resolution),
           "--sampler", sampler, "--out", str(out_exr)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired as exc:
        raise MitsubaError(f"peer_mitsuba.py timed out after {timeout_s:.0f} s") from exc
    if out.returncode != 0:
        tail = (out.stderr.strip() or out.stdout.strip())[-800:]
        raise MitsubaError(f"peer_mitsuba.py exited {out.returncode}: {tail}")
    res = parse_output(out.stdout)
    res["command"] = " ".join(cmd[1:])
    return res
