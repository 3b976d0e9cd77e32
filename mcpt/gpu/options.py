"""What a render is asked for, what the driver limits, and the comparison switches: three of the
four groups of :class:`mcpt.gpu.features.Features` (the fourth, ``Uses``, is what the scene uses and
lives there, with the derivation that fills all four)."""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..errors import McptError

# Where the numbers come from (mcpt/shading/sampler.py, which defines the layout once): "sobol"
# padded Owen-scrambled Sobol' computed in the shader (default: converges faster, no per-pass
# upload), "independent" PCG64 from the host.
SAMPLERS = ("sobol", "independent")

# The estimators of Switches.sampling: MIS, and the two it combines (to check it against).
SAMPLING_MODES = ("mis", "nee", "bsdf")


@dataclass(frozen=True)
class Options:
    """What the render is asked for (the scene's render block and the command line)."""

    bounces: int                    # maximum scattering events (0: emitters only)
    sampler: str = "sobol"          # "sobol" or "independent" (SAMPLERS)
    clamp: bool = False             # biased firefly clamp, off unless asked for
    variance: bool = False          # also accumulate squares (per-pixel variance: --aov variance)
    alpha: bool = False             # transparent film: coverage in the squares target's alpha (needs variance)
    aov: bool = False               # albedo, normal, depth targets (glsl/aov.glsl, --aov, --denoise)

    def __post_init__(self):
        if self.sampler not in SAMPLERS:
            raise ValueError(f"sampler must be one of {SAMPLERS}, got {self.sampler!r}")


@dataclass(frozen=True)
class Limits:
    """What the driver limits (loop_limit_for) and what that means for this scene's paths."""

    loop_limit: int = 0             # the driver's loop-iteration limit (llvmpipe 65535); 0: none
    long_paths: bool = True         # a path may outrun one draw's share of it (needs_continuation)


@dataclass(frozen=True)
class Switches:
    """Comparison and debugging switches; the defaults are what a user renders with.

    ``sampling`` (all unbiased; the tests and the stability suite check them against one another):
    ``"mis"`` light sampling and BSDF sampling combined by the power heuristic; ``"nee"`` light
    sampling only at non-specular vertices (emitters hit by a BSDF-sampled ray count only after a
    specular bounce or from the camera); ``"bsdf"`` no light sampling, emission counts when hit."""

    sampling: str = "mis"           # the estimator: "mis", "nee" or "bsdf" (SAMPLING_MODES)
    russian_roulette: bool = True   # off: paths end at the bounce limit only (from RR_START on)
    counters: bool = False          # count traversal work per ray (bench/counters.py)
    continuation: bool = True       # off: never continue long paths in further draws
    uber: bool = False              # compile every optional code path (Features.everything)
    equiangular: bool = True        # issue #25: equiangular samples towards point/spot lights in a medium
    compute: bool = False           # issue #23: dispatch the path tracer as a compute shader (MCPT_DISPATCH)
    wavefront: bool = False         # ... as two compute kernels with queues between them (needs compute)

    def __post_init__(self):
        if self.sampling not in SAMPLING_MODES:
            raise ValueError(f"sampling must be one of {SAMPLING_MODES}, got {self.sampling!r}")


#: How the path tracer runs (``MCPT_DISPATCH``): "fragment" (default: a full-screen draw, measured
#: on llvmpipe and on NVIDIA H100/H200), "compute" (issue #23: the same GLSL as a compute shader,
#: for GPUs that run fragment work on a few of their units, such as Hopper's) or "wavefront"
#: (issue #23: two compute kernels, shade and trace, with each bounce's rays regrouped between
#: them; mcpt/gpu/wavefront.py).
DISPATCHES = ("fragment", "compute", "wavefront")


class DispatchError(McptError, ValueError):
    """MCPT_DISPATCH names no dispatch, or one that cannot render the scene; one line for the user."""


def dispatch_flags(environ=os.environ) -> dict[str, bool]:
    """The Switches ``MCPT_DISPATCH`` asks for: ``compute`` (compute and wavefront) and ``wavefront``."""
    value = (environ.get("MCPT_DISPATCH") or "fragment").strip().lower()
    if value not in DISPATCHES:
        raise DispatchError(f"MCPT_DISPATCH={value!r}: choose one of {', '.join(DISPATCHES)}")
    return {"compute": value != "fragment", "wavefront": value == "wavefront"}
