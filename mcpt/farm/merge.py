"""Combining renders of one scene: the spp-weighted mean of independent estimates.

Renders made with different seeds are independent estimates of the same image; the one a single
render of the summed spp would give (in expectation and in variance) is their mean weighted by the
passes each holds::

    merged = sum_i spp_i * image_i / sum_i spp_i        (float64, then float32 as every image)

Exactly that, pixel for pixel (a pixel whose non-finite samples were dropped weighs by its spp all
the same: the error is at most dropped/spp of that pixel). The inputs must agree on everything
but the seed and the spp (scene hash, resolution, bounces, compile options): the EXR headers carry
them as ``mcpt:*`` keys (mcpt/farm/session.py). Two renders with the same seed share their passes
(every render starts at pass 0 unless ``--first-pass`` says otherwise), so renders whose pass ranges
of one seed overlap are refused: their mean would count the same paths twice. Disjoint ranges of
one seed (``--first-pass 0..N``, ``N..M``) merge into the image of passes 0..M, up to float32
rounding of the parts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import McptError
from ..output.image import read_exr
from .state import mismatch

COMPARED = ("scene_hash", "width", "height", "bounces", "features_mode", "clamp")


class MergeError(McptError, ValueError):
    pass


def _record(header: dict, path) -> dict:
    rec = {k[len("mcpt:"):]: v for k, v in header.items() if isinstance(k, str) and k.startswith("mcpt:")}
    missing = [k for k in (*COMPARED, "spp", "seed") if k not in rec]
    if missing:
        raise MergeError(f"{path}: not an mcpt render of this version (header lacks mcpt:{missing[0]})")
    return rec


def merge(paths: list[str | Path]) -> tuple[np.ndarray, dict]:
    """The merged image and its header (``mcpt:*`` keys: spp summed, the seeds listed)."""
    if len(paths) < 2:
        raise MergeError("merge needs at least two renders")
    images, records = [], []
    for path in paths:
        try:
            image, header = read_exr(path)
        except FileNotFoundError:
            raise MergeError(f"{path}: no such file") from None
        except Exception as exc:  # OpenEXR reports unreadable files with varied exceptions
            raise MergeError(f"{path}: not a readable EXR ({' '.join(str(exc).split())})") from None
        images.append(image)
        records.append(_record(header, path))
    first = records[0]
    ranges: dict[str, list] = {}  # seed -> [(first pass, end pass, path)]
    for path, rec in zip(paths, records):
        why = mismatch(first, rec, COMPARED, here=str(paths[0]), there=str(path))
        if why:
            raise MergeError(f"cannot merge {path}: {why}")
        lo = int(rec.get("first_pass", 0))
        hi = lo + int(rec["spp"])
        for a, b, other in ranges.get(rec["seed"], []):
            if lo < b and a < hi:
                raise MergeError(f"cannot merge {path}: passes {lo}..{hi - 1} of seed {rec['seed']} "
                                 f"overlap passes {a}..{b - 1} of {other}, so they share paths "
                                 "(render other seeds, or disjoint --first-pass ranges)")
        ranges.setdefault(rec["seed"], []).append((lo, hi, path))
    spp = np.array([int(r["spp"]) for r in records], np.float64)
    acc = np.zeros(images[0].shape, np.float64)
    for n, image in zip(spp, images):
        acc += n * image.astype(np.float64)
    merged = (acc / spp.sum()).astype(np.float32)
    header = {f"mcpt:{k}": first[k] for k in COMPARED}
    header.update({"mcpt:spp": str(int(spp.sum())), "mcpt:seed": first["seed"],
                   "mcpt:seeds": " ".join(r["seed"] for r in records),
                   "mcpt:merged_spp": " ".join(str(int(n)) for n in spp),
                   "mcpt:merged_from": " ".join(str(p) for p in paths)})
    for k in ("scene", "gl_renderer", "mcpt_version", "spp_requested"):
        if k in first:
            header[f"mcpt:{k}"] = first[k]
    return merged, header
