"""Russian roulette (GLSL side: glsl/roulette.glsl).

After scattering at bounce ``k >= RR_START`` a path whose throughput (eta-corrected inside glass)
has fallen to ``q < 1`` survives with probability ``q`` and is divided by it, so the estimate
stays unbiased (pbrt-v4, ``PathIntegrator::Li``). No cap below 1: capping ``q`` at 0.95, as
Mitsuba 3 does, grows survivors' weights by albedo / cap per bounce, a heavy-tailed estimate that
in the albedo-0.999 furnace at 1000 bounces gave 221 for 632.67 (issue #10).

The shader compiles the rule only where ``bounces > RR_START`` (``Features.rr``): shorter paths
never reach it.
"""

from __future__ import annotations

#: Russian roulette starts after this many scattering events (Mitsuba's rr_depth is 5 path
#: segments = 4 scattering events; we start a little earlier, it is unbiased either way).
#: Emitted as ``MCPT_RR_START``.
RR_START = 3
