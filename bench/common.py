"""Pure parts of the benchmarks: image metrics, log-log fits, time to a threshold, JSON records.

Nothing here touches GL, so tests/test_bench.py checks it in milliseconds.

Units: seconds everywhere; errors are dimensionless over all pixels and channels (linear RGB):

* RMSE   = sqrt(mean((x - ref)^2))
* relMSE = mean((x - ref)^2 / (ref^2 + 0.01))     (the peer study's definition)
* MAE    = mean(|x - ref|)
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

# ------------------------------------------------------------------------------------------------
# Metrics
# ------------------------------------------------------------------------------------------------


def rmse(x: np.ndarray, ref: np.ndarray) -> float:
    d = np.asarray(x, np.float64) - np.asarray(ref, np.float64)
    return float(np.sqrt(np.mean(d * d)))


def relmse(x: np.ndarray, ref: np.ndarray, eps: float = 0.01) -> float:
    r = np.asarray(ref, np.float64)
    d = np.asarray(x, np.float64) - r
    return float(np.mean(d * d / (r * r + eps)))


def mae(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.mean(np.abs(np.asarray(x, np.float64) - np.asarray(ref, np.float64))))


def errors(x: np.ndarray, ref: np.ndarray) -> dict:
    return {"rmse": rmse(x, ref), "relmse": relmse(x, ref), "mae": mae(x, ref)}


def downsample(ref: np.ndarray, width: int, height: int) -> np.ndarray:
    """Area-average ``ref`` (H, W, 3) down to (height, width, 3).

    With a one-pixel box filter, a pixel's expected value is the mean radiance over its square,
    so the block mean of a finer reference is exactly the reference of the coarser image.
    """
    h, w = ref.shape[:2]
    if h % height or w % width:
        raise ValueError(f"reference {w}x{h} does not divide into {width}x{height} blocks")
    fy, fx = h // height, w // width
    return ref.reshape(height, fy, width, fx, -1).mean(axis=(1, 3)).astype(ref.dtype)


def to_resolution(ref: np.ndarray, width: int, height: int) -> np.ndarray:
    """``downsample`` where the reference is finer; where it is coarser by a whole factor (the
    256x256 references at the GPU runs' 1024x1024), each reference pixel is repeated. A repeated
    pixel is not the pixel's mean radiance: the relMSE then carries a floor from the edges inside
    a reference pixel, the same for both renderers, so it ranks them but is not an absolute error."""
    h, w = ref.shape[:2]
    if height <= h and width <= w:
        return downsample(ref, width, height)
    if height % h or width % w:
        raise ValueError(f"reference {w}x{h} does not repeat into {width}x{height}")
    return np.repeat(np.repeat(ref, height // h, axis=0), width // w, axis=1)


def luminance(rgb) -> float:
    """Rec. 709 luminance of a linear RGB triple (or the mean of an image's)."""
    r, g, b = (float(v) for v in rgb)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


# ------------------------------------------------------------------------------------------------
# Fits
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PowerFit:
    """y = c * x^slope, fitted as a straight line in log10-log10 space (least squares)."""

    slope: float
    log10_c: float
    r2: float
    n: int

    def predict(self, x):
        return 10.0 ** (self.log10_c + self.slope * np.log10(np.asarray(x, np.float64)))

    def solve(self, y: float) -> float | None:
        """The x where the fit reaches y; None when the fit is flat or rising (never gets there)."""
        if not self.slope < 0 or not math.isfinite(self.slope):
            return None
        return float(10.0 ** ((math.log10(y) - self.log10_c) / self.slope))

    def as_dict(self) -> dict:
        return {"slope": self.slope, "c": 10.0**self.log10_c, "r2": self.r2, "points": self.n}


def fit_power(x, y) -> PowerFit:
    """Least-squares line through (log10 x, log10 y); needs two or more positive points."""
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 2:
        raise ValueError(f"a log-log fit needs two or more positive points, got {x.size}")
    lx, ly = np.log10(x), np.log10(y)
    slope, icpt = np.polyfit(lx, ly, 1)
    res = ly - (icpt + slope * lx)
    tot = ly - ly.mean()
    r2 = 1.0 - float(res @ res) / float(tot @ tot) if float(tot @ tot) > 0 else 1.0
    return PowerFit(float(slope), float(icpt), r2, int(x.size))


@dataclass(frozen=True)
class LogFit:
    """y = a + b * log10(x) (least squares); how BVH time should grow with the triangle count."""

    a: float
    b: float
    r2: float
    n: int

    def predict(self, x):
        return self.a + self.b * np.log10(np.asarray(x, np.float64))

    def as_dict(self) -> dict:
        return {"a": self.a, "b_per_decade": self.b, "r2": self.r2, "points": self.n}


def fit_log(x, y) -> LogFit:
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    if x.size < 2:
        raise ValueError("a fit needs two or more points")
    lx = np.log10(x)
    b, a = np.polyfit(lx, y, 1)
    res = y - (a + b * lx)
    tot = y - y.mean()
    r2 = 1.0 - float(res @ res) / float(tot @ tot) if float(tot @ tot) > 0 else 1.0
    return LogFit(float(a), float(b), r2, int(x.size))


def time_to_threshold(seconds, errs, threshold: float, fit: PowerFit | None = None) -> dict:
    """Seconds needed to bring the error down to ``threshold``.

    Inside the measured range: straight-line interpolation in log-log space between the two
    measured points around the first crossing ("interpolated"). Outside it: along the power-law
    ``fit`` of all points ("extrapolated"), or None when there is no fit or it does not fall.
    Returns {"threshold", "seconds", "method"}.
    """
    t = np.asarray(seconds, np.float64)
    e = np.asarray(errs, np.float64)
    order = np.argsort(t)
    t, e = t[order], e[order]
    for i in range(len(t) - 1):
        e0, e1 = e[i], e[i + 1]
        if e0 >= threshold >= e1 and e0 > 0 and e1 > 0 and t[i] > 0:
            if e0 == e1:
                sec = float(t[i])
            else:
                k = math.log(threshold / e0) / math.log(e1 / e0)
                sec = float(t[i] * (t[i + 1] / t[i]) ** k)
            return {"threshold": threshold, "seconds": sec, "method": "interpolated"}
    if fit is None:
        fit = fit_power(t, e) if len(t) >= 2 else None
    sec = fit.solve(threshold) if fit is not None else None
    return {"threshold": threshold, "seconds": sec,
            "method": "extrapolated" if sec is not None else "not reached"}


def converges(values) -> dict:
    """Bounce-sweep check: the last step is smaller than the one before (|d_n| < |d_{n-1}|)."""
    v = [float(x) for x in values]
    steps = [b - a for a, b in zip(v, v[1:])]
    ok = len(steps) >= 2 and abs(steps[-1]) < abs(steps[-2])
    return {"steps": steps, "converges": bool(ok)}


# ------------------------------------------------------------------------------------------------
# Records
# ------------------------------------------------------------------------------------------------


def alternate(sides: list, render, rounds: int):
    """``render(side, round)`` for every side in every round, the order reversed every other
    round (a side never always goes first on a noisy machine). Returns CPU seconds (the process's:
    llvmpipe's threads included) and wall seconds per side, and each round's results by side."""
    cpu, wall, results = dict.fromkeys(sides, 0.0), dict.fromkeys(sides, 0.0), []
    for k in range(rounds):
        got = {}
        for side in (sides if k % 2 == 0 else sides[::-1]):
            c0, w0 = time.process_time(), time.perf_counter()
            got[side] = render(side, k)
            cpu[side] += time.process_time() - c0
            wall[side] += time.perf_counter() - w0
        results.append(got)
    return cpu, wall, results


def git_revision(root: Path = ROOT) -> dict:
    def git(*args):
        try:
            out = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True, timeout=10)
            return out.stdout.strip() if out.returncode == 0 else None
        except (OSError, subprocess.SubprocessError):
            return None

    rev = git("rev-parse", "HEAD")
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"revision": rev or "unknown", "dirty": bool(status) if status is not None else None}


def loadavg() -> float | None:
    try:
        return round(os.getloadavg()[0], 3)
    except OSError:  # pragma: no cover
        return None


def machine() -> dict:
    import numpy

    try:
        from mcpt import __version__ as mcpt_version
    except Exception:  # pragma: no cover
        mcpt_version = "unknown"
    return {
        "cpus": os.cpu_count(),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "mcpt": mcpt_version,
    }


def run_meta(gl_info: dict | None = None, argv=None) -> dict:
    """What every record file starts with: when, which code, which GL, which machine."""
    return {
        "time_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git": git_revision(),
        "gl": gl_info or {},
        "machine": machine(),
        "loadavg_1min": loadavg(),
        "argv": list(argv if argv is not None else sys.argv),
    }


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _clean(o):
    """NaN and infinities are not JSON: write them as null."""
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {str(k): _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    return o


def write_json(path: Path, data: dict) -> Path:
    """Write ``data`` as indented JSON atomically (temp file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(_clean(json.loads(json.dumps(data, default=_json_default))),
                              indent=1, allow_nan=False) + "\n")
    tmp.replace(path)
    return path


def write_records(out_dir: Path, sweep: str, meta: dict, settings: dict, records: list[dict],
                  summary: dict) -> Path:
    """``<out_dir>/<sweep>.json``: {sweep, meta, settings, records: [...], summary}."""
    return write_json(Path(out_dir) / f"{sweep}.json",
                      {"sweep": sweep, "meta": meta, "settings": settings, "records": records,
                       "summary": summary})


def read_records(path: Path) -> dict:
    return json.loads(Path(path).read_text())
