"""Comparing Monte Carlo images statistically: a per-pixel z-test with a Šidák-corrected level.

Two renders of the same scene are never pixel-identical, so "the same image" means: every
pixel-channel's difference is within what their variances allow. This is how Mitsuba 3 judges its
render tests (``src/render/tests/test_renders.py``)::

    z = (test - ref) / sqrt(var_test + var_ref)       (variances OF THE MEANS)

Each of the N pixel-channels is tested at the Šidák-corrected level
``alpha_pix = 1 - (1 - alpha)^(1/N)`` (alpha = 0.01 for the whole image), and the images agree if
at least 99.75 % of the pixel-channels accept (Mitsuba's figure) and the image mean of every
channel agrees within 4 standard errors (catches a small global bias that no single pixel shows).
Any NaN/Inf or a shape mismatch fails outright. The stability suite (bench/stability/) judges its
renders with :func:`z_test`, the golden tests (tests/goldens.py) theirs; anyone comparing two renders
(or a render with an analytic answer) may call it directly. It lives with the benchmarks, not in
the renderer: rendering never needs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

ALPHA = 0.01            # false-rejection rate for a whole image (before the 99.75 % rule)
ACCEPT = 0.9975         # fraction of pixel-channels that must accept (Mitsuba 3)
GLOBAL_SIGMA = 4.0      # image-mean agreement, in standard errors, per channel
VAR_FLOOR_ABS = 1e-4    # per-sample variance floor (Mitsuba 3: black pixels have no variance)
VAR_FLOOR_REL = 1e-4    # ... plus this times ref^2



def sidak_alpha(alpha: float, n: int) -> float:
    """Per-test level so that n independent tests reject none with probability 1 - alpha."""
    return -math.expm1(math.log1p(-alpha) / max(int(n), 1))


def z_threshold(alpha_pixel: float) -> float:
    """Two-sided standard-normal quantile: P(|Z| > z) = alpha_pixel."""
    return NormalDist().inv_cdf(1.0 - alpha_pixel / 2.0)


@dataclass
class ZTest:
    """Outcome of :func:`z_test`; ``z`` is the signed per-pixel-channel statistic."""

    passed: bool
    accepted: float             # fraction of pixel-channels with |z| <= threshold
    n: int                      # pixel-channels tested
    alpha_pixel: float
    threshold: float
    z: np.ndarray
    global_z: np.ndarray        # per channel: (mean(test) - mean(ref)) / its standard error
    reason: str = ""
    files: list[str] = field(default_factory=list)

    @property
    def rejected(self) -> int:
        return int(round((1.0 - self.accepted) * self.n))

    def summary(self) -> str:
        g = ", ".join(f"{v:+.2f}" for v in np.atleast_1d(self.global_z))
        s = (f"{'PASS' if self.passed else 'FAIL'}: {100 * self.accepted:.2f} % of {self.n} "
             f"pixel-channels within |z| <= {self.threshold:.2f} (Sidak alpha {self.alpha_pixel:.2e},"
             f" need {100 * ACCEPT:.2f} %); image-mean z per channel [{g}] (need |z| < "
             f"{GLOBAL_SIGMA:g})")
        if self.reason:
            s += f"; {self.reason}"
        if self.files:
            s += "; wrote " + ", ".join(self.files)
        return s


def z_test(test, ref, var_test, var_ref, *, var_floor=0.0, alpha: float = ALPHA,
           accept: float = ACCEPT, allow: int = 0, global_sigma: float = GLOBAL_SIGMA) -> ZTest:
    """Per-pixel-channel z-test of two independent Monte Carlo estimates of the same image.

    ``var_test`` / ``var_ref`` are the variances OF THE MEANS (per-sample variance / spp), arrays
    broadcastable to the images, or 0 for an exact reference (analytic value). ``var_floor`` is
    the lower bound of their sum (see the module docstring). The test passes when at least the
    fraction ``accept`` of the values accept, or no more than ``allow`` reject (for tiny images,
    where 0.25 % is less than one pixel).
    """
    a = np.asarray(test, np.float64)
    b = np.asarray(ref, np.float64)
    if a.shape != b.shape:
        z = np.zeros(b.shape)
        return ZTest(False, 0.0, b.size, 0.0, 0.0, z, np.zeros(1),
                     f"shape {a.shape} differs from the reference {b.shape}")
    var = np.asarray(var_test, np.float64) + np.asarray(var_ref, np.float64)
    var = np.maximum(np.broadcast_to(var, a.shape), np.maximum(var_floor, 1e-300))
    n = a.size
    ap = sidak_alpha(alpha, n)
    thr = z_threshold(ap)
    finite = np.isfinite(a)
    with np.errstate(invalid="ignore"):
        z = np.where(finite, (a - b) / np.sqrt(var), np.inf)
    accepted = float(np.mean(np.abs(z) <= thr))
    n_rejected = int(np.sum(~(np.abs(z) <= thr)))
    chans = a.shape[-1] if a.ndim == 3 else 1
    a2, b2, v2 = (x.reshape(-1, chans) for x in (np.where(finite, a, 0.0), b, var))
    global_z = (a2.mean(0) - b2.mean(0)) / np.sqrt(v2.sum(0) / a2.shape[0] ** 2)
    reasons = []
    if not finite.all():
        reasons.append(f"{int((~finite).sum())} non-finite values")
    if accepted < accept and n_rejected > allow:
        reasons.append(f"{n_rejected} pixel-channels rejected")
    if np.any(np.abs(global_z) >= global_sigma):
        reasons.append("image mean differs")
    return ZTest(not reasons, accepted, n, ap, thr, z, global_z, "; ".join(reasons))
