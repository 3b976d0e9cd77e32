"""How soon a render stops, and what cutting draws into bands costs (issue #24 item 8).

    .venv/bin/python -m mcpt.bench.stop_latency                    # all three parts
    .venv/bin/python -m mcpt.bench.stop_latency --only signals --tries 5

* ``signals``: ``mcpt render`` (Cornell box, --resolution, --spp 100000) gets SIGINT, SIGTERM and
  SIGHUP ``--after`` seconds after it started; the seconds from the signal to its exit.
* ``time``: ``mcpt render --time T`` for each ``--budgets``: the wall seconds of the process (from
  its start, Python's included), the target T + max(10 %, 1 s), and what it wrote.
* ``bands``: paths/s of whole draws against draws in bands (mcpt/gpu/bands.py), alternating in one
  process (``--rounds``), wall and CPU seconds (the machine is shared: CPU seconds are the steadier
  measure of the work, wall seconds include the threads waiting for each other at every band);
  then draws of fewer samples (``samples_per_draw`` 32 and 16, which change the pixels) for the
  comparison the issue asked for. The bands are checked to give the same bits.
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import ab

ROOT = Path(__file__).resolve().parent.parent


def _default_signals() -> None:
    """In the child: SIGINT and SIGHUP as a terminal would send them (a benchmark started in the
    background inherits them ignored, and mcpt keeps an ignored signal ignored)."""
    for s in (signal.SIGINT, signal.SIGHUP):
        signal.signal(s, signal.SIG_DFL)


def _mcpt(*args: str) -> subprocess.Popen:
    exe = Path(sys.executable).with_name("mcpt")
    return subprocess.Popen([str(exe), "render", *args, "--progress", "none"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_signals)


def _wait(proc: subprocess.Popen) -> str:
    try:
        return proc.communicate(timeout=120)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()[1] + "\n(killed after 120 s)"


def signals(args, out: Path) -> list[dict]:
    rows = []
    for k in range(args.tries):
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            proc = _mcpt(str(args.scene), "--resolution", args.res, "--spp", "100000",
                         "-o", str(out / f"sig{k}.exr"))
            time.sleep(args.after)
            t = time.perf_counter()
            proc.send_signal(sig)
            err = _wait(proc)
            rows.append({"signal": sig.name, "seconds": time.perf_counter() - t, "rc": proc.returncode,
                         "message": err.strip().splitlines()[-1:]})
            print(f"{sig.name}: exit {proc.returncode} {rows[-1]['seconds']:.2f} s after the signal",
                  flush=True)
    return rows


def budgets(args, out: Path) -> list[dict]:
    rows = []
    for budget in args.budgets:
        for k in range(args.tries):
            t = time.perf_counter()
            proc = _mcpt(str(args.scene), "--resolution", args.res, "--spp", "100000", "--time",
                         str(budget), "-o", str(out / f"t{k}.exr"))
            err = _wait(proc)
            wall = time.perf_counter() - t
            target = budget + max(0.1 * budget, 1.0)
            rows.append({"budget": budget, "wall": wall, "target": target, "rc": proc.returncode,
                         "within": wall <= target, "message": err.strip().splitlines()[-1:]})
            print(f"--time {budget}: {wall:.2f} s wall (target {target:.1f}), exit {proc.returncode}: "
                  f"{rows[-1]['message'][0][:100] if rows[-1]['message'] else ''}", flush=True)
    return rows


def bands(args, out: Path) -> list[dict]:
    """Whole draws, bands, and smaller draws of one prepared scene, alternating."""
    import numpy as np

    from ..prepare import prepare

    rows = []
    w, h = (int(x) for x in args.res.split("x"))
    for name in args.scenes.split(","):
        p = prepare(ab.scene_path(name, out), resolution=(w, h), gl_backend="egl")
        r = p.renderer
        spd = r.samples_per_draw
        ways = {"whole draws": (spd, False), "bands": (spd, True)}
        ways.update({f"{s} samples a draw": (s, False) for s in (spd // 2, spd // 4) if s >= 4})

        def draw(way, r=r, ways=ways):
            r.samples_per_draw, banded = ways[way]
            t, c = time.perf_counter(), time.process_time()
            sums = list(r.passes(0, 0, args.spp, interrupt=lambda summed: False,
                                 drop_draw=(lambda summed, done: False) if banded else None))
            return time.perf_counter() - t, time.process_time() - c, sums

        try:
            ref = draw("whole draws")[2]  # also the warm-up (the driver compiles at first draw)
            wall = dict.fromkeys(ways, 0.0)
            cpu = dict.fromkeys(ways, 0.0)
            same = True
            for k in range(args.rounds):
                for way in (list(ways) if k % 2 == 0 else list(ways)[::-1]):
                    dw, dc, sums = draw(way)
                    wall[way] += dw
                    cpu[way] += dc
                    if way == "bands":
                        same &= all(a[0] == b[0] and np.array_equal(a[1], b[1]) for a, b in zip(sums, ref))
            paths = w * h * args.spp * args.rounds
            for way in ways:
                rows.append({"scene": name, "way": way, "samples_per_draw": ways[way][0],
                             "paths_per_second": paths / wall[way], "cpu_seconds": cpu[way] / args.rounds,
                             "wall_ratio": wall["whole draws"] / wall[way],
                             "cpu_ratio": cpu["whole draws"] / cpu[way],
                             **({"same_bits": same} if way == "bands" else {})})
                print(f"{name} {way}: {rows[-1]['paths_per_second'] / 1e6:.3f} Mpaths/s "
                      f"(x{rows[-1]['wall_ratio']:.3f} wall, x{rows[-1]['cpu_ratio']:.3f} CPU of whole "
                      f"draws)" + (f", same bits: {same}" if way == "bands" else ""), flush=True)
        finally:
            r.samples_per_draw = spd
            r.release()
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=["signals", "time", "bands"], default=None)
    ap.add_argument("--scene", type=Path, default=ROOT / "scenes" / "cornell-box.yaml")
    ap.add_argument("--res", default="256x256")
    ap.add_argument("--after", type=float, default=3.0, help="seconds before the signal")
    ap.add_argument("--tries", type=int, default=2)
    ap.add_argument("--budgets", type=float, nargs="+", default=[2.0, 5.0, 10.0])
    ap.add_argument("--scenes", default="cornell,bunny", help="bands: scenes (bench/ab.py names)")
    ap.add_argument("--spp", type=int, default=128, help="bands: passes a round")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench" / "stop_latency")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"args": {k: str(v) for k, v in vars(args).items()}}
    with tempfile.TemporaryDirectory() as tmp:
        for part, fn in (("signals", signals), ("time", budgets), ("bands", bands)):
            if args.only in (None, part):
                result[part] = fn(args, Path(tmp) if part != "bands" else args.out)
    (args.out / "stop_latency.json").write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out / 'stop_latency.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
