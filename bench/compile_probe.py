"""Cold shader-compile figures, measured in a fresh process with Mesa's disk shader cache off.

    python -m mcpt.bench.compile_probe SCENE.yaml scene|all [--gl-backend egl]

prints one JSON line: compile_seconds (GLSL compile + link, mcpt's own figure), first_pass_seconds
(the first 1-spp draw of a 16x16 image: llvmpipe turns the shader into machine code there),
second_pass_seconds (the same draw again, to subtract). In the benchmark process itself Mesa's
on-disk cache (~/.cache/mesa_shader_cache) and mcpt's program cache make repeat compiles nearly
free, which is what a user sees on the second run but not what specialisation costs.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

ENV = {"MESA_SHADER_CACHE_DISABLE": "true", "MESA_GLSL_CACHE_DISABLE": "true"}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    scene, mode = argv[0], argv[1]
    backend = argv[argv.index("--gl-backend") + 1] if "--gl-backend" in argv else None
    from mcpt.api import Options, prepare, run

    p = prepare(scene, resolution=(16, 16), features_mode=mode, gl_backend=backend)
    t0 = time.perf_counter()
    run(p, Options(spp=1, seed=0))
    t1 = time.perf_counter()
    run(p, Options(spp=1, seed=0))
    t2 = time.perf_counter()
    print(json.dumps({"compile_seconds": p.renderer.setup["compile_seconds"],
                      "first_pass_seconds": t1 - t0, "second_pass_seconds": t2 - t1,
                      "shader_cache_disabled": os.environ.get("MESA_SHADER_CACHE_DISABLE") == "true"}))
    p.renderer.release()
    return 0


def run(scene: Path, mode: str, gl_backend: str | None = None, timeout: float = 300.0) -> dict:
    """Run this probe in a fresh interpreter and return its figures (or {"error": ...})."""
    import subprocess

    cmd = [sys.executable, "-m", "mcpt.bench.compile_probe", str(scene), mode]
    if gl_backend:
        cmd += ["--gl-backend", gl_backend]
    env = {**os.environ, **ENV}
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:.0f} s"}
    if out.returncode != 0:
        return {"error": (out.stderr.strip().splitlines() or ["?"])[-1]}
    try:
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return {"error": f"unreadable output: {out.stdout[-200:]!r}"}


if __name__ == "__main__":
    sys.exit(main())
