"""Farm benchmark (issue #11): the Cornell box in one process against a 2-worker Dask
LocalCluster, on this machine. Not a test: timings live here, not in tests/.

Each side runs ``mcpt render --json`` in a fresh process (LP_NUM_THREADS must be set before Mesa
starts), the sides alternating (A, B, C, A, B, C, ...) so that the load of a shared machine falls
on all of them alike:

* ``one-process LP=2``   one process, llvmpipe with 2 threads (what a user gets by default here)
* ``one-process LP=1``   one process, 1 llvmpipe thread (the per-worker baseline)
* ``2 workers LP=1``     ``--workers 2``: two spawned worker processes, 1 llvmpipe thread each

Reported: wall time of the command, the passes' time (the render's ``render_seconds``; for the
farm minus the LocalCluster start-up, reported apart), the scaling against one process, and the
Dask overhead per task: measured directly (a round trip of empty tasks on a 2-worker LocalCluster)
and as the farm's pass time less the ideal (one-thread pass time / 2), per task.

    python -m mcpt.bench.farm --resolution 64 --spp 512 --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell-box.yaml"


def _children_cpu() -> float:
    """User + system seconds of every finished descendant (the workers are reaped by their nanny,
    the nanny by mcpt, mcpt by us), llvmpipe's threads included: a figure the load of a shared
    machine does not inflate, unlike wall time."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_side(name: str, args, env_extra: dict, out: Path) -> dict:
    exe = Path(sys.executable).with_name("mcpt")
    env = {**os.environ, **env_extra}
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run([str(exe), "render", str(SCENE), *args, "-o", str(out), "--json", "--quiet"],
                          capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0
    if proc.returncode != 0:
        raise SystemExit(f"{name}: {proc.stderr.strip()}")
    s = json.loads(proc.stdout)
    farm = s.get("farm", {})
    passes = s["render_seconds"] - farm.get("cluster_seconds", 0.0)
    return {"side": name, "wall": wall, "cpu": cpu, "passes": passes, "cluster": farm.get("cluster_seconds"),
            "tasks": farm.get("tasks"), "spp": s["spp"]}


def empty_task_overhead(n_tasks: int = 200) -> float:
    """Seconds per empty task through a 2-worker LocalCluster (submit, run, gather)."""
    from distributed import Client, wait

    from mcpt.farm.cluster import local_cluster

    with local_cluster(2, lp_threads=1) as cluster, Client(cluster) as client:
        client.submit(int, 0).result()  # warm
        t0 = time.perf_counter()
        futs = [client.submit(int, i, pure=False) for i in range(n_tasks)]
        wait(futs)
        client.gather(futs)
        return (time.perf_counter() - t0) / n_tasks


def main(argv=None) -> None:
    import logging

    logging.getLogger("distributed").setLevel(logging.CRITICAL)  # shutdown chatter of the workers
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default="out/bench-farm")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    common = ["--resolution", f"{a.resolution}x{a.resolution}", "--spp", str(a.spp), "--seed", "1"]
    sides = [("one-process LP=2", [], {"LP_NUM_THREADS": "2"}),
             ("one-process LP=1", [], {"LP_NUM_THREADS": "1"}),
             ("2 workers LP=1", ["--workers", "2"], {"LP_NUM_THREADS": "1"})]
    rows = []
    for r in range(a.rounds):
        for name, extra, env in sides:
            row = run_side(name, common + extra, env, out / f"{name.split()[0]}-{r}.exr")
            rows.append(row)
            print(json.dumps(row), flush=True)
    overhead = empty_task_overhead()
    med = {name: {k: statistics.median(x[k] for x in rows if x["side"] == name)
                  for k in ("wall", "cpu", "passes")} for name, _, _ in sides}
    tasks = next(x["tasks"] for x in rows if x["tasks"])
    cluster = statistics.median(x["cluster"] for x in rows if x["cluster"] is not None)
    one2, one1, farm = (med[s[0]] for s in sides)
    derived = (farm["passes"] - one1["passes"] / 2) / (tasks / 2)
    lines = [
        f"Cornell box {a.resolution}x{a.resolution}, {a.spp} spp, 8 bounces; {a.rounds} rounds, "
        f"sides alternating; medians. {tasks} tasks of 64 passes.",
        "",
        "| side | wall s (command) | CPU s (all processes) | passes s | passes speed-up vs "
        "one-process LP=1 | vs LP=2 |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, _, _ in sides:
        m = med[name]
        lines.append(f"| {name} | {m['wall']:.2f} | {m['cpu']:.2f} | {m['passes']:.2f} | "
                     f"{one1['passes'] / m['passes']:.2f}x | {one2['passes'] / m['passes']:.2f}x |")
    lines += ["",
              f"- LocalCluster start-up (2 spawned workers): {cluster:.2f} s (inside the farm's wall time).",
              f"- Dask overhead per task, empty tasks through a 2-worker LocalCluster: "
              f"{overhead * 1e3:.2f} ms.",
              f"- Farm pass time less the ideal (one-thread pass time / 2), per task and worker: "
              f"{derived:.3f} s (includes each worker's first-task set-up: scene, BVH, compile)."]
    lines.append(f"- CPU seconds of the farm over one process LP=1: "
                 f"{farm['cpu'] - one1['cpu']:+.2f} s (Dask, two interpreters, two compiles).")
    text = "\n".join(lines)
    print(text)
    (out / "RESULTS.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
