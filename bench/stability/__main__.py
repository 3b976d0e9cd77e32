"""`make stability`: run the stability suite of issue #6 and print one table row per case.

    .venv/bin/python -m mcpt.bench.stability [--gl-backend egl|osmesa] [--only TEXT ...] [--json FILE]

Columns: group, case, expected, measured, result (PASS, FAIL, or KNOWN FAIL for a case whose
cause and fix are reported, see bench/stability/), seconds. The cases are the ones
tests/test_stability.py runs in CI. Exit status 1 when a case fails that is not a known failure.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import textwrap
import time
from pathlib import Path

from mcpt.bench import stability

GROUP_ORDER = ["furnace", "scale", "offset", "watertight", "lights", "geometry", "limits",
               "non-finite", "determinism", "llvmpipe", "deep"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gl-backend", default=None, help="egl or osmesa (default: $MCPT_GL_BACKEND)")
    ap.add_argument("--only", nargs="*", default=[], help="run cases whose name or group contains TEXT")
    ap.add_argument("--json", default=None, help="also write the rows as JSON to this file")
    ap.add_argument("--width", type=int, default=46, help="wrap expected/measured at this width")
    args = ap.parse_args(argv)

    cases = [c for c in stability.CASES
             if not args.only or any(t in c.name or t == c.group for t in args.only)]
    cases.sort(key=lambda c: GROUP_ORDER.index(c.group) if c.group in GROUP_ORDER else 99)
    rows = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mcpt-stability-") as tmp:
        env = stability.Env(Path(tmp), args.gl_backend)
        print(f"mcpt stability suite on {env.gl.renderer} ({env.gl.backend}), {len(cases)} cases\n")
        w = args.width
        head = f"{'group':<11} {'case':<37} {'expected':<{w}} {'measured':<{w}} {'result':<10} {'s':>5}"
        print(head)
        print("-" * len(head))
        for c in cases:
            r = stability.run_case(c, env)
            rows.append(r)
            exp = textwrap.wrap(r.outcome.expected, w) or [""]
            mea = textwrap.wrap(r.outcome.measured, w) or [""]
            for i in range(max(len(exp), len(mea))):
                first = i == 0
                print(f"{c.group if first else '':<11} {c.name if first else '':<37} "
                      f"{exp[i] if i < len(exp) else '':<{w}} {mea[i] if i < len(mea) else '':<{w}} "
                      f"{r.status if first else '':<10} {f'{r.seconds:5.2f}' if first else ''}")
    secs = time.perf_counter() - t0
    passed = sum(r.outcome.passed for r in rows)
    known = [r for r in rows if not r.outcome.passed and r.known]
    failed = [r for r in rows if not r.outcome.passed and not r.known]
    print(f"\n{passed} passed, {len(known)} known failures, {len(failed)} failed, "
          f"{len(rows)} cases in {secs:.1f} s")
    for r in known:
        print(f"\nKNOWN {r.case.name}:\n" + textwrap.indent(textwrap.fill(r.known, 100), "  "))
    if args.json:
        Path(args.json).write_text(json.dumps([
            {"group": r.case.group, "case": r.case.name, "expected": r.outcome.expected,
             "measured": r.outcome.measured, "passed": bool(r.outcome.passed), "status": r.status,
             "known": r.known, "seconds": round(r.seconds, 3)} for r in rows], indent=2))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
