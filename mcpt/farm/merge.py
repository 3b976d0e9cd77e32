"""Combining renders of one scene: the spp-weighted mean of independent estimates.

Renders made with different seeds are independent estimates of the same image; the one a single
render of the summed spp would give (in expectation and in variance) is their mean weighted by the
passes each holds::

    merged = sum_i spp_i * image_i / sum_i spp_i        (float64, then float32 as every image)

Exactly that, pixel for pixel (a pixel whose non-finite samples were dropped weighs by its spp all
the same: the error is at most dropped/spp of that pixel). The inputs must agree on everything
but the seed and the spp (scene hash, resolution, bounces, compile options): the EXR headers carry
them as ``mcpt:*`` keys (mcpt/output/metadata.py). Two renders with the same seed share their passes
(every render starts at pass 0 unless ``--first-pass`` says otherwise), so renders whose pass ranges
of one seed overlap are refused: their mean would count the same paths twice. Disjoint ranges of
one seed (``--first-pass 0..N``, ``N..M``) merge into the image of passes 0..M, up to float32
rounding of the parts.

AOV layers (``--aov``, mcpt/gpu/aov.py) are merged too; the inputs must have the same ones.
Albedo and depth are per-sample means, so they merge like the beauty (exactly as one render of
all the passes); the normal is merged so and scaled back to unit length, which is only
approximately one render's normal where a pixel straddles an edge (each input's mean normal was
already normalised, so how much its directions disagreed is lost: degrees at such pixels, exact
on flat ones); variance, the variance of each input's mean,
merges as that of the weighted mean, ``sum_i spp_i^2 var_i / (sum_i spp_i)^2``. A denoised input
(``mcpt:denoised``) is biased, so its raw beauty (``raw.R/G/B``) is what is merged; ``denoise``
runs OIDN again on the merged beauty with the merged albedo and normal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import McptError
from ..gpu import aov as aov_mod
from ..output.image import read_exr_channels
from .state import mismatch

COMPARED = ("scene_hash", "width", "height", "bounces", "features_mode", "clamp")


class MergeError(McptError, ValueError):
    pass


def _record(header: dict, path) -> dict:
    rec = {k[len("mcpt:"):]: v for k, v in header.items() if isinstance(k, str) and k.startswith("mcpt:")}
    missing = [k for k in (*COMPARED, "spp", "seed") if k not in rec]
    if missing:
        raise MergeError(f"{path}: not an mcpt render of this version (header lacks mcpt:{missing[0]})")
    for key, value in rec.items():  # mcpt writes every mcpt:* key as text (output/image.py)
        if not isinstance(value, str):
            raise MergeError(f"{path}: header key mcpt:{key} holds {type(value).__name__} {value!r}, "
                             "not the text mcpt writes")
    _check_numbers(rec, path)
    return rec


def _whole(rec: dict, key: str, path, least: int, text: str | None = None) -> int:
    """The number mcpt:``key`` (or ``text``, one entry of its list) holds: decimal digits, >= least
    (issue #24 item 16: "abc", "1e3" were internal errors, -8 spp an image of inf and NaN)."""
    value = rec[key] if text is None else text
    if not (value.isascii() and value.isdigit()) or int(value) < least:
        what = "a whole number" if text is None else "a list of whole numbers"
        raise MergeError(f"{path}: header key mcpt:{key} is {rec[key]!r}, not {what} >= {least}")
    return int(value)


def _check_numbers(rec: dict, path) -> None:
    """The counts the merge computes with, checked before any arithmetic."""
    for key, least in (("spp", 1), ("width", 1), ("height", 1), ("first_pass", 0)):
        if key in rec:
            _whole(rec, key, path, least)
    if _whole(rec, "seed", path, 0) >= 2**63:
        raise MergeError(f"{path}: header key mcpt:seed is {rec['seed']!r}, above the largest seed (2^63 - 1)")
    if "seeds" in rec:
        seeds = rec["seeds"].split()
        lists = {"seeds": seeds, "merged_spp": rec.get("merged_spp", "").split(),
                 "merged_first_pass": rec.get("merged_first_pass", " ".join("0" * len(seeds))).split()}
        if len({len(v) for v in lists.values()}) != 1:
            raise MergeError(f"{path}: a merged input whose mcpt:seeds, mcpt:merged_spp and "
                             "mcpt:merged_first_pass disagree in length")
        for key, least in (("seeds", 0), ("merged_spp", 1), ("merged_first_pass", 0)):
            for text in lists[key]:
                _whole(rec, key, path, least, text)
        if sum(int(n) for n in lists["merged_spp"]) != int(rec["spp"]):
            raise MergeError(f"{path}: header key mcpt:merged_spp ({rec.get('merged_spp')}) does not "
                             f"add up to mcpt:spp ({rec['spp']})")


def _check_pixels(channels: dict, rec: dict, path) -> None:
    """Every channel as large as the header says (issue #24 item 16: 16x16 pixels under a 32x32
    header was a broadcast error)."""
    expected = (int(rec["height"]), int(rec["width"]))
    for name, pixels in channels.items():
        if pixels.shape != expected:
            raise MergeError(f"{path}: channel {name} holds {'x'.join(map(str, pixels.shape[::-1]))} "
                             f"pixels, its header says {rec['width']}x{rec['height']} (mcpt:width, mcpt:height)")


def _beauty(channels: dict, rec: dict, path) -> np.ndarray:
    """The unbiased beauty of one input: ``raw.R/G/B`` where it was denoised, else ``R/G/B``."""
    prefix = "raw." if "denoised" in rec else ""
    try:
        return np.stack([channels[f"{prefix}{c}"] for c in "RGB"], axis=-1)
    except KeyError:
        what = "a denoised render without its raw.R/G/B" if prefix else "no R/G/B channels"
        raise MergeError(f"{path}: {what}") from None


def _layer(channels: dict, name: str, path) -> np.ndarray:
    letters = aov_mod.AOVS[name][0]
    try:
        return np.stack([channels[f"{name}.{c}"] for c in letters], axis=-1)
    except KeyError:
        raise MergeError(f"{path}: its header lists the AOV {name!r} but the file lacks its channels") from None


def _aovs(rec: dict) -> tuple[str, ...]:
    return aov_mod.parse(rec.get("aovs", ""))


def _read_all(paths) -> tuple[list, list]:
    """Every input's channels and its record; a missing or unreadable file is one line."""
    files, records = [], []
    for path in paths:
        try:
            channels, header = read_exr_channels(path, with_header=True)
        except FileNotFoundError:
            raise MergeError(f"{path}: no such file") from None
        except McptError:  # read_exr_channels's one line (ImageError)
            raise
        except Exception as exc:  # noqa: BLE001 - other read failures (a folder, permissions)
            raise MergeError(f"{path}: not a readable EXR ({' '.join(str(exc).split())})") from None
        records.append(_record(header, path))
        _check_pixels(channels, records[-1], path)
        files.append(channels)
    return files, records


def _check_compatible(paths, records) -> None:
    """Inputs merge only when rendered alike (COMPARED, the same AOV layers) and no two share a
    pass of one seed (they would share paths: the merge would not be one render's image)."""
    first = records[0]
    ranges: dict[str, list] = {}  # seed -> [(first pass, end pass, path)]
    for path, rec in zip(paths, records):
        why = mismatch(first, rec, COMPARED, here=str(paths[0]), there=str(path))
        if not why and _aovs(rec) != _aovs(first):
            why = (f"its AOV layers ({','.join(_aovs(rec)) or 'none'}) differ from those of "
                   f"{paths[0]} ({','.join(_aovs(first)) or 'none'})")
        if why:
            raise MergeError(f"cannot merge {path}: {why}")
        for seed, lo, hi in pass_ranges(rec):
            for a, b, other in ranges.get(seed, []):
                if lo < b and a < hi:
                    raise MergeError(f"cannot merge {path}: its passes {lo}..{hi - 1} of seed {seed} "
                                     f"overlap passes {a}..{b - 1} of seed {seed} in {other}, so they "
                                     "share paths (render other seeds, or disjoint --first-pass ranges)")
            ranges.setdefault(seed, []).append((lo, hi, path))


def pass_ranges(rec: dict) -> list[tuple[str, int, int]]:
    """The (seed, first pass, end pass) ranges an input holds: one for a render, one per merged
    render for a merge (its ``mcpt:seeds``, ``mcpt:merged_spp``, ``mcpt:merged_first_pass``;
    issue #24: a merge's own ``mcpt:seed`` names only its first part, so seed 2 of a merge of
    seeds 1 and 2 was counted twice when merged with seed 2 again)."""
    if "seeds" not in rec:
        lo = int(rec.get("first_pass", 0))
        return [(rec["seed"], lo, lo + int(rec["spp"]))]
    seeds = rec["seeds"].split()  # checked by _record: equal lengths, whole numbers
    spps = [int(n) for n in rec.get("merged_spp", "").split()]
    firsts = [int(n) for n in rec.get("merged_first_pass", " ".join("0" * len(seeds))).split()]
    return [(seed, lo, lo + n) for seed, n, lo in zip(seeds, spps, firsts)]


def merge(paths: list[str | Path], denoise: bool = False) -> tuple[np.ndarray, dict, dict]:
    """The merged image, its header (``mcpt:*`` keys: spp summed, the seeds listed) and its AOV
    layers (the ``layers`` argument of mcpt.output.image.write_exr)."""
    if len(paths) < 2:
        raise MergeError("merge needs at least two renders")
    if denoise:
        from ..output.denoise import denoise as oidn
        from ..output.denoise import version

        denoiser = version()  # DenoiseError (one line) before any work when the extra is missing
    files, records = _read_all(paths)
    first = records[0]
    _check_compatible(paths, records)
    spp = np.array([int(r["spp"]) for r in records], np.float64)
    w = spp / spp.sum()

    def mean(arrays) -> np.ndarray:
        acc = np.zeros(arrays[0].shape, np.float64)
        for n, a in zip(spp, arrays):
            acc += n * a.astype(np.float64)
        return (acc / spp.sum()).astype(np.float32)

    merged = mean([_beauty(ch, rec, path) for ch, rec, path in zip(files, records, paths)])
    names = _aovs(first)
    values = {}
    for name in names:
        parts = [_layer(ch, name, path) for ch, path in zip(files, paths)]
        if name == "variance":  # of the weighted mean of independent estimates
            values[name] = sum(wi * wi * p.astype(np.float64) for wi, p in zip(w, parts)).astype(np.float32)
        elif name == "normal":
            n = mean(parts).astype(np.float64)
            length = np.linalg.norm(n, axis=-1, keepdims=True)
            values[name] = (n * np.divide(1.0, length, out=np.zeros_like(length),
                                          where=length > 1e-12)).astype(np.float32)
        else:
            values[name] = mean(parts)
    layers = aov_mod.layers(values, names)
    header = {f"mcpt:{k}": first[k] for k in COMPARED}
    header.update({"mcpt:spp": str(int(spp.sum())), "mcpt:seed": first["seed"],
                   "mcpt:seeds": " ".join(seed for r in records for seed, _, _ in pass_ranges(r)),
                   "mcpt:merged_spp": " ".join(str(hi - lo) for r in records for _, lo, hi in pass_ranges(r)),
                   "mcpt:merged_first_pass": " ".join(str(lo) for r in records for _, lo, _ in pass_ranges(r)),
                   "mcpt:merged_from": " ".join(str(p) for p in paths)})
    for k in ("scene", "gl_renderer", "mcpt_version", "spp_requested", "aovs"):
        if k in first:
            header[f"mcpt:{k}"] = first[k]
    if any("denoised" in r for r in records):
        header["mcpt:merged_beauty"] = "raw.R/G/B of the denoised inputs (unbiased)"
    if denoise:
        missing = [n for n in aov_mod.DENOISE_AOVS if n not in values]
        if missing:
            raise MergeError(f"--denoise needs the {' and '.join(missing)} layers in every input "
                             "(render them with --aov albedo,normal)")
        raw = merged
        merged = oidn(raw, values["albedo"], values["normal"])
        header["mcpt:denoised"] = f"{denoiser}, biased"
        layers = {"raw": (raw, "RGB"), **layers}
    return merged, header, layers
