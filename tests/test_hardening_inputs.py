"""Issue #24 (hardening, second pass), items 15 and 16 and the leftovers of items 5 and 9: damaged
or crafted checkpoints and merge inputs are one mcpt line and exit 2, a state path that is not a
regular file is refused before it is opened, and a finished render's image has priority over its
checkpoint on a full disk. Each test failed before its fix."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from . import test_farm as farm
from .test_farm import header, invoke, mcpt

STATE = "c.exr.state.npz"


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """test_farm's lit floor and box (12x10 pixels): seeds 1 and 2 at 8 spp, and a checkpoint of
    100 passes (64 in ``complete``, 36 in ``partial``) with its image."""
    d = tmp_path_factory.mktemp("made")
    for name, text in (("floor.obj", farm.FLOOR_OBJ), ("box.obj", farm.BOX_OBJ),
                       ("light.obj", farm.LIGHT_OBJ), ("scene.yaml", farm.SCENE)):
        (d / name).write_text(text)
    cwd = os.getcwd()
    os.chdir(d)
    try:
        for seed in (1, 2):
            assert invoke("scene.yaml", "--seed", str(seed), "--spp", "8", "-o", f"s{seed}.exr").exit_code == 0
        assert invoke("scene.yaml", "--spp", "100", "--checkpoint", "1000", "-o", "c.exr").exit_code == 0
    finally:
        os.chdir(cwd)
    return d


@pytest.fixture
def folder(made, tmp_path, monkeypatch):
    for p in made.iterdir():
        shutil.copy(p, tmp_path / p.name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def one_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


# ---- 15. a damaged or crafted checkpoint was an internal error (or a numpy hint) --------------

def _state_arrays(made) -> tuple[dict, dict]:
    with np.load(made / STATE) as z:
        arrays = {k: z[k] for k in z.files}
    return arrays, json.loads(arrays["meta"].tobytes().decode())


def _crafted(made, meta_text: str | None = None, **changes) -> bytes:
    """The good checkpoint with record keys or arrays changed (None: removed)."""
    arrays, meta = _state_arrays(made)
    for key, value in changes.items():
        target = arrays if key in ("complete", "partial") else meta
        if value is None:
            target.pop(key)
        else:
            target[key] = value(arrays[key]) if callable(value) else value
    text = json.dumps(meta) if meta_text is None else meta_text
    arrays["meta"] = np.frombuffer(text.encode(), np.uint8)
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def _flip(data: bytes) -> bytes:
    b = bytearray(data)
    b[len(b) // 2] ^= 0xFF
    return bytes(b)


DAMAGED = {  # name: (the file's bytes from the good ones, what the message says)
    "empty": (lambda good, made: b"", "the file is empty"),
    "one byte": (lambda good, made: good[:1], "not a zip archive"),
    "100 bytes": (lambda good, made: good[:100], "truncated or altered"),
    "half": (lambda good, made: good[:len(good) // 2], "truncated or altered"),
    "all but one byte": (lambda good, made: good[:-1], "truncated or altered"),
    "random bytes": (lambda good, made: np.random.default_rng(5).bytes(5000), "not a zip archive"),
    "a flipped byte": (lambda good, made: _flip(good), "truncated or altered"),
    "chunk 0": (lambda good, made: _crafted(made, chunk=0), "chunk is 0, not a whole number >= 1"),
    "negative done": (lambda good, made: _crafted(made, done=-5), "done is -5, not a whole number >= 0"),
    "done abc": (lambda good, made: _crafted(made, done="abc"), 'done is "abc", not a whole number'),
    "done float": (lambda good, made: _crafted(made, done=100.0), "done is 100.0, not a whole number"),
    "no done": (lambda good, made: _crafted(made, done=None), "done is null"),
    "NaN sums": (lambda good, made: _crafted(made, complete=lambda a: np.full_like(a, np.nan)),
                 "complete holds NaN or infinite sums"),
    "inf partial": (lambda good, made: _crafted(made, partial=lambda a: np.full_like(a, np.inf)),
                    "partial holds NaN or infinite sums"),
    "wrong shape": (lambda good, made: _crafted(made, complete=np.zeros((1, 16, 16, 4)),
                                                partial=np.zeros((1, 16, 16, 4), np.float32)),
                    "complete has shape (1, 16, 16, 4), this render's sums (1, 10, 12, 4)"),
    "float32 complete": (lambda good, made: _crafted(made, complete=lambda a: a.astype(np.float32)),
                         "complete holds float32 values, mcpt writes float64"),
    "no partial": (lambda good, made: _crafted(made, partial=None), "100 passes in chunks of 64 but it has no"),
    "a stray partial": (lambda good, made: _crafted(made, done=64), "64 passes in chunks of 64 but it holds"),
    "no sums": (lambda good, made: _crafted(made, complete=None), "it lacks the complete sums"),
    "record not JSON": (lambda good, made: _crafted(made, meta_text="{done"), "(meta) is not JSON"),
    "record a list": (lambda good, made: _crafted(made, meta_text="[1, 2]"), "(meta) is not a JSON object"),
    "other chunk": (lambda good, made: _crafted(made, chunk=3),
                    "cannot resume: chunk is 64 in this render but 3 in the checkpoint"),
    "more targets": (lambda good, made: _crafted(made, complete=np.zeros((2, 10, 12, 4)),
                                                 partial=np.zeros((2, 10, 12, 4), np.float32)),
                     "it holds 2 accumulation targets, this render 1"),
}


@pytest.mark.parametrize("case", DAMAGED)
def test_a_damaged_or_crafted_checkpoint_is_one_line(folder, made, case):
    make, says = DAMAGED[case]
    state = make((made / STATE).read_bytes(), made)
    (folder / STATE).write_bytes(state)
    image = (folder / "c.exr").read_bytes()
    r = invoke("scene.yaml", "--spp", "200", "--resume", "-o", "c.exr")
    assert r.exit_code == 2, r.output
    line = one_line(r)
    assert line.startswith(f"mcpt: error: {STATE}: ") and says in line, line
    assert "pickle" not in line and "numpy" not in line, line
    assert (folder / STATE).read_bytes() == state and (folder / "c.exr").read_bytes() == image


def test_the_checks_pass_a_good_checkpoint_and_load_reads_it_as_written(folder, made):
    from mcpt.farm import state as st

    acc, meta = st.load(STATE)
    arrays, _ = _state_arrays(made)
    assert (acc.spp, acc.chunk, meta["done"]) == (100, 64, 100)
    assert farm.same_bits(acc.complete, arrays["complete"]) and farm.same_bits(acc.partial, arrays["partial"])
    r = invoke("scene.yaml", "--spp", "200", "--resume", "-o", "c.exr")
    assert r.exit_code == 0 and header("c.exr")["mcpt:spp"] == "200", r.output


# ---- 9. a FIFO at the state path blocked the set-up (a stop signal did not end it) ------------

@pytest.mark.parametrize("args", [["--resume"], ["--checkpoint", "5", "--overwrite"]])
def test_a_state_path_that_is_not_a_regular_file_is_refused(folder, args):
    (folder / STATE).unlink()
    os.mkfifo(folder / STATE)
    p = mcpt("render", "scene.yaml", "--spp", "8", *args, "-o", "c.exr", "--quiet", cwd=folder)
    try:
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:  # the old code blocked in open(): end it (it ignores one SIGTERM)
            p.kill()
            p.communicate()
    assert p.returncode == 2 and out == "", (out, err)
    assert err.strip() == f"mcpt: error: {STATE}: is a FIFO, not a checkpoint file"


def test_a_folder_at_the_state_path_is_refused(folder):
    (folder / STATE).unlink()
    (folder / STATE).mkdir()
    r = invoke("scene.yaml", "--spp", "8", "--resume", "-o", "c.exr")
    assert r.exit_code == 2 and one_line(r) == f"mcpt: error: {STATE}: is a folder, not a checkpoint file"


# ---- 5. on a nearly full disk the last state file kept the final image from being written ----

def test_a_finished_render_writes_its_image_before_its_state(folder, monkeypatch):
    """The disk holds the earlier checkpoint's state or the new image, not both: the state makes
    room, the image of every pass lands, and the state is written again after it."""
    from mcpt import render as render_mod
    from mcpt.farm import state as st
    from mcpt.output.image import ImageError

    real = render_mod.write_images

    def full(paths, *args, **kw):
        if (folder / STATE).exists():
            raise ImageError(f"{paths[0]}: cannot write the image: No space left on device.")
        return real(paths, *args, **kw)

    monkeypatch.setattr(render_mod, "write_images", full)
    r = invoke("scene.yaml", "--spp", "128", "--checkpoint", "1000", "--resume", "-o", "c.exr")
    assert r.exit_code == 0, r.output
    assert f"removing the earlier checkpoint {STATE} to make room" in r.stderr
    assert header("c.exr")["mcpt:spp"] == "128"
    assert st.load(STATE)[0].spp == 128


def test_a_full_disk_keeps_the_finished_image_on_a_small_tmpfs(folder):
    """As the audit found it: a 200 KiB tmpfs holding the checkpoint of 384 of 512 passes."""
    if os.geteuid() != 0 or not shutil.which("mount"):
        pytest.skip("mounting a tmpfs needs root")
    disk = folder / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(disk)]).returncode:
        pytest.skip("no tmpfs here")
    try:
        out = str(disk / "o.exr")
        base = ("scene.yaml", "--resolution", "64x64", "--checkpoint", "1000", "-o", out)
        assert invoke(*base, "--spp", "384").exit_code == 0
        free = os.statvfs(disk)
        (disk / "filler").write_bytes(bytes(free.f_bavail * free.f_frsize - 8192))  # 8 KiB left
        r = invoke(*base, "--spp", "512", "--resume")
        assert r.exit_code == 0, r.output
        assert header(out)["mcpt:spp"] == "512"
    finally:
        subprocess.run(["umount", str(disk)], check=True)


# ---- 16. crafted merge inputs were internal errors, or an image of inf and NaN ---------------

def _craft_exr(made, path, edit=None, pixels=None) -> None:
    """s1.exr with its mcpt:* header keys edited (None: removed), or its pixels replaced by zeros
    of another size."""
    import OpenEXR

    with OpenEXR.File(str(made / "s1.exr"), separate_channels=True) as f:
        hdr = {k: v for k, v in f.header().items() if k.startswith("mcpt:")}
        channels = {k: np.array(c.pixels) for k, c in f.channels().items()}
    for k, v in (edit or {}).items():
        if v is None:
            hdr.pop(k)
        else:
            hdr[k] = v
    if pixels is not None:
        channels = {k: np.zeros(pixels, np.float32) for k in channels}
    hdr.update(compression=OpenEXR.ZIP_COMPRESSION, type=OpenEXR.scanlineimage)
    OpenEXR.File(hdr, channels).write(str(path))


CRAFTED = {  # name: (header edits, pixels, what the message says)
    "spp abc": ({"mcpt:spp": "abc"}, None, "mcpt:spp is 'abc', not a whole number >= 1"),
    "spp 1e3": ({"mcpt:spp": "1e3"}, None, "mcpt:spp is '1e3', not a whole number >= 1"),
    "spp -8": ({"mcpt:spp": "-8"}, None, "mcpt:spp is '-8', not a whole number >= 1"),
    "spp 0": ({"mcpt:spp": "0"}, None, "mcpt:spp is '0', not a whole number >= 1"),
    "first_pass abc": ({"mcpt:first_pass": "abc"}, None, "mcpt:first_pass is 'abc', not a whole number >= 0"),
    "seed an int": ({"mcpt:seed": 1}, None, "mcpt:seed holds int 1, not the text mcpt writes"),
    "seed abc": ({"mcpt:seed": "abc"}, None, "mcpt:seed is 'abc'"),
    "seed 2^63": ({"mcpt:seed": str(2**63)}, None, "above the largest seed"),
    "width x": ({"mcpt:width": "x"}, None, "mcpt:width is 'x'"),
    "pixels smaller than the header": ({"mcpt:width": "32", "mcpt:height": "32"}, (16, 16),
                                       "holds 16x16 pixels, its header says 32x32"),
    "merged_spp short": ({"mcpt:seeds": "1 3", "mcpt:merged_spp": "8"}, None, "disagree in length"),
    "merged_spp abc": ({"mcpt:seeds": "1 3", "mcpt:merged_spp": "4 x"}, None,
                       "mcpt:merged_spp is '4 x', not a list of whole numbers >= 1"),
    "merged_spp not the spp": ({"mcpt:seeds": "1 3", "mcpt:merged_spp": "8 8"}, None,
                               "mcpt:merged_spp (8 8) does not add up to mcpt:spp (8)"),
}


@pytest.mark.parametrize("case", CRAFTED)
def test_a_crafted_merge_input_is_one_line(folder, made, case):
    edit, pixels, says = CRAFTED[case]
    _craft_exr(made, folder / "x.exr", edit, pixels)
    r = invoke("x.exr", "s2.exr", "-o", "m.exr", command="merge")
    assert r.exit_code == 2, r.output
    line = one_line(r)
    assert line.startswith("mcpt: error: x.exr: ") and says in line, line
    assert not (folder / "m.exr").exists()


@pytest.mark.parametrize("name,make,says", [
    ("trunc.exr", lambda s: s[:3000], "not a readable EXR ("),  # OpenEXR's own words vary
    ("flip.exr", lambda s: s[:-40] + bytes(b ^ 0xFF for b in s[-40:]), "not a readable EXR ("),
    ("t100.exr", lambda s: s[:100], "not a readable EXR ("),
    ("empty.exr", lambda s: b"", "not an EXR file (empty)"),
    ("s8.png", None, "not an EXR file (a PNG)"),
])
def test_an_unreadable_merge_input_prints_mcpt_s_line_only(folder, name, make, says):
    """OpenEXR prints its reasons from C++ on stdout and stderr: only mcpt's line is seen (a
    subprocess, since they are written to the file descriptors)."""
    if make is None:
        assert invoke("scene.yaml", "--spp", "8", "-o", name).exit_code == 0
    else:
        (folder / name).write_bytes(make((folder / "s1.exr").read_bytes()))
    p = mcpt("merge", name, "s2.exr", "-o", "m.exr", cwd=folder)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 2 and out == "", (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"mcpt: error: {name}: ") and says in lines[0], lines
    assert not (folder / "m.exr").exists()


def test_a_merge_of_good_inputs_still_merges(folder):
    r = invoke("s1.exr", "s2.exr", "-o", "m.exr", command="merge")
    assert r.exit_code == 0, r.output
    assert header("m.exr")["mcpt:spp"] == "16" and header("m.exr")["mcpt:seeds"] == "1 2"
