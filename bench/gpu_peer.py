"""mcpt beside Mitsuba 3 ``cuda_ad_rgb`` on a real GPU (issue #23's H100 target), one run, alternating.

    MCPT_PEER_PYTHON=... python -m mcpt.bench.gpu_peer -o out/gpu-peer [--resolution 1024]

The same sweep as ``mcpt bench --only peer`` (bench/peer_run.py: the shared Cornell box and 100k
sphere, mcpt and Mitsuba alternating per (round, scene, spp), each tool's own render timer, set-up
excluded), at the issue's 1024x1024 and with Mitsuba's CUDA variant. Writes peer.json and PEER.md
to the output folder. The 256x256 references are repeated up to 1024x1024 (common.to_resolution):
the relMSE column ranks the two renderers but carries the same floor for both.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from . import peer_run, sweeps


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m mcpt.bench.gpu_peer", description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--out", type=Path, default=Path("out/gpu-peer"))
    ap.add_argument("--resolution", type=int, default=1024, help="square, pixels (default 1024)")
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--variant", default="cuda_ad_rgb", help="Mitsuba variant (default cuda_ad_rgb)")
    ap.add_argument("--samplers", default="sobol,sobol@compute,sobol@wavefront",
                    help="mcpt samplers, comma-separated; SAMPLER@DISPATCH: with MCPT_DISPATCH=DISPATCH")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    cfg = sweeps.config(True, out=a.out, gl_backend="egl")
    pc = peer_run.peer_config(True, resolution=a.resolution, spp=tuple(a.spp), rounds=a.rounds,
                              variant=a.variant, mcpt_samplers=tuple(a.samplers.split(",")))
    res = peer_run.peer_sweep(cfg, log=lambda m: print(m, file=sys.stderr, flush=True), pcfg=pc)
    (a.out / "peer.json").write_text(json.dumps(res, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
