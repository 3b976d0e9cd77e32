"""Deep paths: roulette without a cap, paths continued across draws (issue #10 item 1).

The albedo-0.999 furnace is stiff: the old survival probability min(max(beta), 0.95) gave 221 for
632.67 at 1000 bounces; pbrt-v4's rule (glsl/pathtrace.frag) and paths continued across draws
where llvmpipe caps loop iterations (glsl/path_state.glsl) reach the analytic value. 4x4 pixels
x 64 spp keep the suite short (~1000 bounces a path); `make stability` prints the same rows.
"""

from __future__ import annotations

from .core import Env, Outcome, case, render
from .furnace import _furnace_case, furnace_scene

_furnace_case("furnace-a0.999-b1000", 0.999, 1000, spp=64, res=4, group="deep")
_furnace_case("furnace-a0.999-b100000", 0.999, 100_000, spp=64, res=4, group="deep")


@case("deep-paths-continue", "deep")
def _deep_continued(env: Env) -> Outcome:
    """20000 bounces at albedo 1 without roulette (~6 loop-limits' worth of iterations a path):
    every path is continued across draws to its end, L = 20001, none dropped."""
    sc = furnace_scene(env, "deep-continued", 1.0, 20000, res=4)
    res, _ = render(env, sc, 2, seed=3, russian_roulette=False)
    mean = float(res.image.mean())
    draws = res.setup.get("continuation_draws", 0)
    return Outcome("L = 20001, none dropped", f"mean {mean:.1f}, {res.dropped_samples} dropped, "
                   f"{draws} continuation draws", res.dropped_samples == 0 and abs(mean / 20001 - 1) < 1e-3)
