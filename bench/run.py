"""Benchmarks of mcpt: ``python -m mcpt.bench.run --quick`` (make bench) or ``--full``; ``mcpt bench`` is the same.

    python -m mcpt.bench.run --quick                 all sweeps, a few minutes on 2 cores
    python -m mcpt.bench.run --full --only error     one sweep, the long version
    python -m mcpt.bench.run --only triangles,bounces -o out/bench-tris

Sweeps: bounces, triangles, error, throughput (paths/s + specialisation). Results go to
``--out`` (default out/bench): <sweep>.json, PNG plots, REPORT.md. Exit status 1 if a sweep failed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mcpt.gpu.context import BACKENDS

from . import suite, sweeps


def parse(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m mcpt.bench.run", description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", dest="quick", action="store_true", default=True,
                      help="small images and few samples: a few minutes in all (default)")
    mode.add_argument("--full", dest="quick", action="store_false",
                      help="256x256, more samples, 1024 spp error sweep, 4.4M-triangle level")
    ap.add_argument("--only", action="append", metavar="SWEEPS",
                    help=f"comma-separated sweeps: {', '.join(suite.ALL)} (default all)")
    ap.add_argument("-o", "--out", type=Path, default=Path("out/bench"), help="output folder")
    ap.add_argument("--seed", type=int, default=0, help="seed of every render (default 0)")
    ap.add_argument("--gl-backend", choices=BACKENDS, default=None)
    ap.add_argument("--brute-cap", type=float, default=None, metavar="SECONDS",
                    help="skip brute force where its projected time passes this")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    a = parse(argv)
    try:
        names = suite.resolve(a.only)
    except ValueError as exc:
        print(f"bench: error: {exc}", file=sys.stderr)
        return 2
    cfg = sweeps.config(a.quick, out=a.out, seed=a.seed, gl_backend=a.gl_backend,
                        brute_cap_seconds=a.brute_cap)
    res = suite.run(names, cfg, log=lambda m: print(m, file=sys.stderr, flush=True),
                    argv=["bench/run.py", *(argv if argv is not None else sys.argv[1:])])
    return 1 if res["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
