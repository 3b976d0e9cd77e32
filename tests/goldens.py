"""Statistical golden images: is a fresh render the same image as the stored reference?

A Monte Carlo render is never pixel-identical to a reference made with other random numbers (or
on another Mesa build), so goldens are judged the way Mitsuba 3 judges its render tests
(``src/render/tests/test_renders.py``): a per-pixel, per-channel **z-test** of the difference
between the test image and the reference mean, using the reference's per-sample variance::

    z = (test - ref) / sqrt(var_sample / spp_test + var_sample / spp_ref)

with the variance floored (black pixels have none: floor = 1e-4 + 1e-4 * ref^2 per sample, as
Mitsuba floors at 1e-4). Each of the N pixel-channels is tested at the **Šidák-corrected** level
``alpha_pix = 1 - (1 - alpha)^(1/N)`` (alpha = 0.01 for the whole image), and the image passes if
at least **99.75 %** of the pixel-channels accept (Mitsuba's figure) and the image mean of every
channel agrees within 4 standard errors (catches a small global bias that no single pixel shows).
Any NaN/Inf or a shape mismatch fails outright. On failure :func:`write_report` writes the test,
reference, difference and |z| images (EXR) and a PNG mask of the rejected pixels.

A golden is one ``.npz`` per scene in ``tests/golden/``: ``mean`` and ``var`` (per-sample
variance, i.e. spp x the variance of the mean), float32 (H, W, 3), and ``meta`` (JSON: GL
renderer and version, back end, spp, seed, bounces, resolution, mcpt version, SHA-256 of the scene
file and its meshes, date). Regenerate every golden with ONE command::

    make goldens            # = .venv/bin/python -m tests.goldens   (see --help)

The test (tests/test_golden.py) renders each scene fresh with a DIFFERENT seed and few samples.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mcpt import __version__
from mcpt.bench.stats import VAR_FLOOR_ABS, VAR_FLOOR_REL, ZTest, sidak_alpha, z_test, z_threshold  # noqa: F401 (re-exported)

from .draw import render as draw

ROOT = Path(__file__).resolve().parent.parent
GOLDEN_DIR = ROOT / "tests" / "golden"



@dataclass(frozen=True)
class GoldenSpec:
    """How one golden is made and tested."""

    name: str
    scene: str                      # path relative to the repository root
    resolution: tuple[int, int]
    ref_spp: int                    # reference: many samples, mean + variance
    ref_seed: int
    test_spp: int                   # the CI test: few samples, another seed
    test_seed: int
    bounces: int | None = None      # None: the scene file's value
    clamp: float | None = None      # BIASED, on reference and test alike: caustic scenes (below)


GOLDENS: dict[str, GoldenSpec] = {
    s.name: s for s in (
        GoldenSpec("cornell-box", "scenes/cornell-box.yaml", (64, 64), 4096, 1_000_003, 64, 7),
        GoldenSpec("furnace", "scenes/furnace.yaml", (32, 32), 4096, 1_000_004, 32, 8),
        # Materials (issue #3). Caustics (light off a mirror, through glass or off the gold onto
        # a diffuse wall, found only by BSDF sampling) are rare (~1e-4 per sample) and large
        # (~10): a 4096-spp reference holds too few to estimate their variance and a 64-spp test
        # that draws one is 10-20 standard errors off. Those scenes clamp each sample at 1.0 on
        # BOTH sides: a clamped image is compared with a clamped image, so a wrong BSDF,
        # texture, normal or bias still shows. The Spot has no caustics and is not clamped.
        GoldenSpec("cornell-spheres", "scenes/cornell-spheres.yaml", (32, 32), 4096, 2_000_003, 64, 17,
                   6, clamp=1.0),
        GoldenSpec("bunny-metal", "scenes/bunny-metal.yaml", (32, 32), 4096, 2_000_004, 64, 18, 4,
                   clamp=1.0),
        GoldenSpec("spot", "scenes/spot.yaml", (32, 32), 4096, 2_000_005, 64, 19, 4),
        # Issue #13: exact conductor Fresnel (gold, rough copper), the F = 1 reference mirror and
        # a cube textured through its MTL; smooth metals make caustics: clamped like the above.
        GoldenSpec("metals", "scenes/metals.yaml", (64, 64), 4096, 2_000_006, 64, 20, 4, clamp=1.0),
    )
}


def write_report(out_dir: str | Path, name: str, test, ref, result: ZTest) -> list[str]:
    """Difference images for a failed comparison: test, ref, test - ref, |z| (EXR) and a PNG mask
    of the rejected pixels (white). Returns the paths written (also stored in ``result.files``)."""
    from mcpt.output.image import write_exr, write_png

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    test = np.asarray(test, np.float32)
    ref = np.asarray(ref, np.float32)
    z = np.abs(np.nan_to_num(result.z, nan=np.inf)).astype(np.float32)
    mask = (z > result.threshold).any(axis=-1) if z.ndim == 3 else z > result.threshold
    files = []
    for suffix, img in (("test", test), ("ref", ref), ("diff", test - ref), ("absz", z)):
        p = out / f"{name}-{suffix}.exr"
        write_exr(p, np.nan_to_num(img, nan=0.0, posinf=1e30, neginf=-1e30))
        files.append(str(p))
    p = out / f"{name}-rejected.png"
    write_png(p, np.repeat(mask[..., None].astype(np.float32), 3, axis=-1))
    files.append(str(p))
    result.files = files
    return files


# ------------------------------------------------------------------------------------------------
# Stored goldens
# ------------------------------------------------------------------------------------------------

@dataclass
class Golden:
    mean: np.ndarray    # (H, W, 3) float32 reference mean
    var: np.ndarray     # (H, W, 3) float32 per-sample variance
    meta: dict


def golden_path(name: str, directory: str | Path | None = None) -> Path:
    return Path(directory or GOLDEN_DIR) / f"{name}.npz"


def save(path: str | Path, mean: np.ndarray, var: np.ndarray, meta: dict) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez_compressed(tmp, mean=np.asarray(mean, np.float32), var=np.asarray(var, np.float32),
                        meta=np.array(json.dumps(meta, sort_keys=True)))
    tmp.replace(path)


def load(path: str | Path) -> Golden:
    with np.load(path, allow_pickle=False) as f:
        return Golden(f["mean"], f["var"], json.loads(str(f["meta"])))


def scene_digest(scene_file: str | Path) -> str:
    """SHA-256 over the scene file and every mesh it uses: a changed scene makes a golden stale."""
    from mcpt.scene import load_scene

    scene_file = Path(scene_file)
    h = hashlib.sha256(scene_file.read_bytes())
    for m in load_scene(scene_file).meshes:
        h.update(Path(m.file).read_bytes())
    return h.hexdigest()


def render_spec(spec: GoldenSpec, spp: int, seed: int, gl_backend: str | None = None,
                sampler: str | None = None):
    """Render a golden's scene; returns (mean, per-sample variance, metadata)."""
    from mcpt.api import prepare

    scene_file = ROOT / spec.scene
    p = prepare(scene_file, resolution=spec.resolution, bounces=spec.bounces, gl_backend=gl_backend,
                feature_flags={"variance": True}, clamp=spec.clamp, sampler=sampler)
    try:
        res = draw(p.renderer, spp, seed)
    finally:
        p.renderer.release()
    meta = {
        "name": spec.name, "scene": spec.scene, "scene_sha256": scene_digest(scene_file),
        "resolution": list(spec.resolution), "spp": spp, "seed": seed, "bounces": res.bounces,
        "clamp": spec.clamp, "dropped_samples": res.dropped_samples, "gl_backend": p.gl.backend,
        "sampler": p.features.sampler,
        "gl_renderer": p.gl.renderer, "gl_version": p.gl.version, "mcpt_version": __version__,
        "render_seconds": round(res.render_seconds, 3),
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }
    return res.image, res.variance * np.float32(spp), meta


def compare(spec: GoldenSpec, golden: Golden, test: np.ndarray, test_spp: int) -> ZTest:
    """z-test of a fresh render (``test_spp`` samples) against a stored golden."""
    ref_spp = int(golden.meta["spp"])
    var = golden.var.astype(np.float64)
    floor = (VAR_FLOOR_ABS + VAR_FLOOR_REL * golden.mean.astype(np.float64) ** 2) / test_spp
    return z_test(test, golden.mean, var / test_spp, var / ref_spp, var_floor=floor)


def check(name: str, *, directory=None, report_dir=None, gl_backend=None,
          spp: int | None = None, seed: int | None = None) -> ZTest:
    """Render golden ``name`` fresh (the spec's test spp and seed unless given) and compare.

    Fails (not raises) when the golden is missing or stale; writes difference images into
    ``report_dir`` when the comparison fails.
    """
    spec = GOLDENS[name]
    path = golden_path(name, directory)
    if not path.is_file():
        return ZTest(False, 0.0, 0, 0.0, 0.0, np.zeros(0), np.zeros(1),
                     f"no golden at {path}; run `make goldens`")
    golden = load(path)
    digest = scene_digest(ROOT / spec.scene)
    if golden.meta.get("scene_sha256") != digest:
        return ZTest(False, 0.0, 0, 0.0, 0.0, np.zeros(0), np.zeros(1),
                     f"{path} was made from another version of {spec.scene}; run `make goldens`")
    spp = spp or spec.test_spp
    seed = spec.test_seed if seed is None else seed
    if seed == golden.meta.get("seed"):
        raise ValueError("the test must use another seed than the reference")
    mean, _, meta = render_spec(spec, spp, seed, gl_backend)
    result = compare(spec, golden, mean, spp)
    if meta["dropped_samples"]:
        result.passed = False
        result.reason = (result.reason + "; " if result.reason else "") + \
            f"{meta['dropped_samples']} non-finite samples"
    if not result.passed and report_dir is not None:
        write_report(report_dir, name, mean, golden.mean, result)
    return result


def regenerate(names=None, *, directory=None, spp: int | None = None, gl_backend=None,
               log=print) -> list[Path]:
    """Render and store the goldens (all, or ``names``)."""
    written = []
    for name in names or list(GOLDENS):
        spec = GOLDENS[name]
        n = spp or spec.ref_spp
        mean, var, meta = render_spec(spec, n, spec.ref_seed, gl_backend)
        if meta["dropped_samples"]:
            raise RuntimeError(f"{name}: {meta['dropped_samples']} non-finite samples in the reference")
        path = golden_path(name, directory)
        save(path, mean, var, meta)
        log(f"{path}: {spec.resolution[0]}x{spec.resolution[1]}, {n} spp, seed {spec.ref_seed}, "
            f"{meta['render_seconds']:.1f} s on {meta['gl_renderer']} ({meta['gl_backend']})")
        written.append(path)
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.goldens",
                                 description="Regenerate (default) or check the golden images.")
    ap.add_argument("names", nargs="*", metavar="NAME",
                    help=f"goldens to process (default: all of {', '.join(GOLDENS)})")
    ap.add_argument("--check", action="store_true", help="compare fresh renders instead of regenerating")
    ap.add_argument("--dir", default=str(GOLDEN_DIR), help="golden folder (default: tests/golden)")
    ap.add_argument("--spp", type=int, default=None, help="override the reference (or test) spp")
    ap.add_argument("--gl-backend", default=None, help="egl or osmesa (default: $MCPT_GL_BACKEND)")
    ap.add_argument("--report-dir", default=str(ROOT / "out" / "golden"),
                    help="where --check writes difference images of failures")
    args = ap.parse_args(argv)
    unknown = [n for n in args.names if n not in GOLDENS]
    if unknown:
        ap.error(f"unknown golden(s) {', '.join(unknown)}; known: {', '.join(GOLDENS)}")
    if not args.check:
        regenerate(args.names or None, directory=args.dir, spp=args.spp, gl_backend=args.gl_backend)
        return 0
    ok = True
    for name in args.names or list(GOLDENS):
        r = check(name, directory=args.dir, report_dir=args.report_dir, gl_backend=args.gl_backend,
                  spp=args.spp)
        print(f"{name}: {r.summary()}")
        ok &= r.passed
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
