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

#: Russian roulette starts after this many scattering events, as Mitsuba 3's ``rr_depth`` 5 (its
#: depth counts scattering events: the check follows ``depth += 1``). Issue #23: starting after
#: the 3rd was the whole of mcpt's extra error per sample against Mitsuba (relMSE x spp at 256 spp,
#: 128x128: Cornell box 0.175 -> 0.131, 100k sphere 0.092 -> 0.065; the two renderers'
#: independent samplers then agree: Cornell 0.272 / 0.269 at 256 spp, sphere 0.149 / 0.152 at 64)
#: for 1.23x the rays (Cornell) and 1.28x the traversal iterations (sphere), counted: time to an
#: error x0.92 / x0.91 by the counts, x0.79-0.99 timed (bench/sampler-quality.md).
#: Emitted as ``MCPT_RR_START``.
RR_START = 5
