"""The set-up cache (mcpt/cache.py, mcpt/shapes/world_cache.py) and the hashed duplicate search
(mcpt/shapes/dedup.py): a cached world is the built world, array for array and pixel for pixel; an
edited file, a truncated or foreign entry never reaches a render; concurrent writers leave one
whole entry. Every test has its own cache folder (MCPT_CACHE_DIR)."""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil

import numpy as np
import pytest
import yaml

from mcpt import cache
from mcpt.scene import load_scene
from mcpt.shapes import dedup
from mcpt.shapes.world import load_world
from mcpt.shapes.world_cache import cached_world

from .conftest import ROOT
from .draw import render as draw

CORNELL = ROOT / "scenes" / "cornell-box.yaml"
SPOT_SCENE = ROOT / "scenes" / "spot.yaml"  # texture, UVs and smooth normals: every World field


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MCPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("MCPT_CACHE", raising=False)
    monkeypatch.delenv("MCPT_CACHE_MAX_MB", raising=False)
    return tmp_path / "cache"


def world_arrays(w) -> dict:
    out = {"tris": w.tris, "tri_material": w.tri_material, "nodes": w.bvh.nodes, "order": w.bvh.order,
           "light_tris": w.lights.triangles, "light_pmf": w.lights.pmf, "albedo": w.materials.albedo,
           "emission": w.materials.emission, "normals": w.normals, "uvs": w.uvs}
    out.update({f"texture{i}": t.srgb for i, t in enumerate(w.textures)})
    return out


def assert_same_world(a, b):
    wa, wb = world_arrays(a), world_arrays(b)
    assert wa.keys() == wb.keys()
    for k in wa:
        assert (wa[k] is None) == (wb[k] is None), k
        if wa[k] is not None:
            assert wa[k].dtype == wb[k].dtype and np.array_equal(wa[k], wb[k]), k
    assert a.materials.names == b.materials.names and a.lights.total_power == b.lights.total_power
    assert (a.bvh.depth, a.bvh.max_leaf) == (b.bvh.depth, b.bvh.max_leaf)


def small_scene(tmp_path, obj_text: str):
    """A Cornell box whose tall box is the OBJ ``obj_text`` written to tmp_path/box.obj."""
    (tmp_path / "box.obj").write_text(obj_text)
    doc = yaml.safe_load(CORNELL.read_text())
    for m in doc["meshes"]:
        m["file"] = str(tmp_path / "box.obj") if "tall_box" in m["file"] else str(CORNELL.parent / m["file"])
    (tmp_path / "s.yaml").write_text(json.dumps(doc))
    return tmp_path / "s.yaml"


def entries(folder, kind="world"):
    cache.wait()  # entries are written in the background
    return sorted((folder / kind).glob("*.npz"))


def test_cached_world_equals_the_built_one_and_renders_the_same_pixels(own_cache):
    from mcpt.api import prepare

    built = load_world(load_scene(SPOT_SCENE))
    first = prepare(SPOT_SCENE, resolution=(16, 16))
    second = prepare(SPOT_SCENE, resolution=(16, 16))
    off = prepare(SPOT_SCENE, resolution=(16, 16), cache=False)
    assert (first.world.stats["cache"], second.world.stats["cache"]) == ("miss", "hit")
    assert "cache" not in off.world.stats and len(entries(own_cache)) == 1
    for p in (first, second, off):
        assert_same_world(built, p.world)
    images = [draw(p.renderer, 2, seed=3).image for p in (off, second)]
    for p in (first, second, off):
        p.renderer.release()
    assert np.array_equal(images[0], images[1])


def test_render_settings_share_an_entry_and_the_camera_position_does_not(own_cache):
    scene = load_scene(CORNELL)
    cached_world(scene, load_world)
    w = cached_world(scene.with_overrides(spp=7, seed=3, resolution=(8, 8)), load_world)
    assert w.stats["cache"] == "hit" and len(entries(own_cache)) == 1
    moved = scene.model_copy(update={"camera": scene.camera.model_copy(update={"position": (0.0, 0.0, 4.0)})})
    w = cached_world(moved, load_world)
    assert w.stats["cache"] == "miss" and len(entries(own_cache)) == 2
    assert_same_world(w, load_world(moved))


def test_an_edited_mesh_misses_the_cache(tmp_path, own_cache):
    path = small_scene(tmp_path, "v 0 -1 0\nv 0.5 -1 0\nv 0 0 0\nf 1 2 3\n")
    a = cached_world(load_scene(path), load_world)
    assert cached_world(load_scene(path), load_world).stats["cache"] == "hit"
    (tmp_path / "box.obj").write_text("v 0 -1 0\nv 0.5 -1 0\nv 0 0.5 0\nf 1 2 3\n")
    b = cached_world(load_scene(path), load_world)
    assert b.stats["cache"] == "miss" and len(entries(own_cache)) == 2
    assert_same_world(b, load_world(load_scene(path)))
    assert not np.array_equal(np.sort(a.tris.ravel()), np.sort(b.tris.ravel()))


def test_an_edited_mtl_file_misses_the_cache(tmp_path):
    (tmp_path / "box.mtl").write_text("newmtl m\nKd 0.1 0.2 0.3\n")
    path = small_scene(tmp_path, "mtllib box.mtl\nv 0 -1 0\nv 0.5 -1 0\nv 0 0 0\nusemtl m\nf 1 2 3\n")
    doc = json.loads(path.read_text())
    for m in doc["meshes"]:
        if m["file"].endswith("box.obj"):
            del m["material"]
    path.write_text(json.dumps(doc))
    a = cached_world(load_scene(path), load_world)
    (tmp_path / "box.mtl").write_text("newmtl m\nKd 0.7 0.2 0.3\n")
    b = cached_world(load_scene(path), load_world)
    assert b.stats["cache"] == "miss"
    assert not np.array_equal(a.materials.albedo, b.materials.albedo)
    assert_same_world(b, load_world(load_scene(path)))


@pytest.mark.parametrize("damage", ["truncate", "garbage", "foreign"])
def test_a_damaged_or_foreign_entry_is_ignored_and_replaced(damage, own_cache):
    scene = load_scene(CORNELL)
    built = cached_world(scene, load_world)
    (entry,) = entries(own_cache)
    if damage == "truncate":
        entry.write_bytes(entry.read_bytes()[: entry.stat().st_size // 2])
    elif damage == "garbage":
        entry.write_bytes(b"PK\x03\x04" + os.urandom(1000))
    else:  # a valid entry of another key, stored under this key's name
        other = cache.Store("world")
        other.put("0" * 64, {"class": "builtins:dict", "fields": {}, "deps": {}}, {"x": np.zeros(3)})
        shutil.copy(other.path("0" * 64), entry)
    again = cached_world(scene, load_world)
    assert again.stats["cache"] == "miss"
    assert_same_world(built, again)
    assert cached_world(scene, load_world).stats["cache"] == "hit"  # replaced by a whole entry


def test_a_foreign_class_name_is_never_imported(own_cache):
    store = cache.Store("world")
    key = "1" * 64
    store.put(key, {"class": "os:system", "fields": {}, "deps": {}}, {})
    from mcpt.shapes import world_cache

    assert world_cache._from_entry(load_scene(CORNELL), *store.get(key)) is None


def test_the_cache_can_be_switched_off(own_cache, monkeypatch):
    monkeypatch.setenv("MCPT_CACHE", "0")
    w = cached_world(load_scene(CORNELL), load_world)
    cache.wait()
    assert "cache" not in w.stats and not own_cache.exists()


def test_least_recently_used_entries_go_when_the_cap_is_reached(own_cache, monkeypatch):
    store = cache.Store("world")
    blob = {"x": np.zeros(300_000, np.uint8)}  # ~0.3 MB each
    for i, key in enumerate("abc"):
        store.put(key * 64, {}, blob)
        os.utime(store.path(key * 64), (1000 + i, 1000 + i))
    assert store.get("a" * 64) is not None  # a hit makes "a" the most recent
    monkeypatch.setenv("MCPT_CACHE_MAX_MB", "0.7")
    store.put("d" * 64, {}, blob)
    left = {p.name[0] for p in entries(own_cache)}
    assert left == {"a", "d"}


def _write_and_read(args):
    folder, key, n, rounds = args
    os.environ["MCPT_CACHE_DIR"] = folder
    store = cache.Store("world")
    seen = 0
    for r in range(rounds):
        store.put(key, {"r": r}, {"x": np.full(n, 7, np.int64)})
        got = store.get(key)
        if got is not None:  # a reader sees a whole entry or none, never a partial one
            assert got[1]["x"].shape == (n,) and (got[1]["x"] == 7).all()
            seen += 1
    return seen


def test_concurrent_writers_leave_one_whole_entry(own_cache):
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        seen = pool.map(_write_and_read, [(str(own_cache), "e" * 64, 2_000_000, 6)] * 2)
    assert sum(seen) == 12  # every read after a write found a whole entry (no partial one deleted)
    assert [p.name for p in entries(own_cache)] == ["e" * 64 + ".npz"]
    assert not list((own_cache / "world").glob(".tmp-*"))


def _cold_world(folder):
    os.environ["MCPT_CACHE_DIR"] = folder
    w = cached_world(load_scene(CORNELL), load_world)
    cache.wait()  # a pool's worker is terminated, not shut down: finish the write first
    return w.tris.tobytes(), w.bvh.nodes.tobytes()


def test_two_processes_building_the_same_scene_at_once(own_cache):
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        a, b = pool.map(_cold_world, [str(own_cache)] * 2)
    assert a == b
    assert cached_world(load_scene(CORNELL), load_world).stats["cache"] == "hit"
    assert not list((own_cache / "world").glob(".tmp-*"))


def _sorted_first(rows):
    """The row-sorting reference of first_of_rows (what np.unique(axis=0) computed)."""
    _, first = np.unique(rows, axis=0, return_index=True)
    return np.sort(first)


@pytest.mark.parametrize("seed", range(5))
def test_hashed_duplicate_search_equals_row_sorting(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    v = (rng.integers(-2, 3, (12, 3)) * 0.5).astype(np.float32)
    faces = rng.integers(0, 12, (500, 3))
    tris = v[faces]
    corners = np.ascontiguousarray(tris.reshape(-1, 3)).view(np.uint32)
    _, ids = np.unique(corners, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    rot = (np.argmin(ids, axis=1)[:, None] + np.arange(3)) % 3
    expected = _sorted_first(np.take_along_axis(ids, rot, axis=1))
    assert np.array_equal(dedup.first_of_repeated_corners(tris), expected)
    rot_f = (np.argmin(faces, axis=1)[:, None] + np.arange(3)) % 3
    expected_f = _sorted_first(np.take_along_axis(faces, rot_f, axis=1))
    assert np.array_equal(dedup.first_of_duplicates(faces), expected_f)
    # Hash collisions between different rows take the exact path: same answer.
    real = dedup.row_hash
    monkeypatch.setattr(dedup, "row_hash", lambda rows: real(rows) & np.uint64(7))
    assert np.array_equal(dedup.first_of_duplicates(faces), expected_f)
    assert np.array_equal(dedup.first_of_repeated_corners(tris), expected)
    # Above, 376-438 of the 500 triangles share an order-free key (dedup._corner_sum_key) and
    # go to the exact search alone; with keys that collide more, all 500 do: same answer. Equal
    # triangles keep equal keys, as the real key guarantees.
    key = dedup._corner_sum_key
    monkeypatch.setattr(dedup, "_corner_sum_key", lambda w: np.where(key(w) % 2 == 0, key(w) & 7, key(w)))
    assert np.array_equal(dedup.first_of_repeated_corners(tris), expected)


def test_repeats_across_rotations_found_and_reversals_kept():
    """The rotation-free hash that skips the exact search when nothing repeats: a rotated copy
    is a repeat, a reversed one (the other side of the surface) is not."""
    rng = np.random.default_rng(7)
    tris = rng.random((1000, 3, 3)).astype(np.float32)
    assert np.array_equal(dedup.first_of_repeated_corners(np.concatenate([tris, tris[:, ::-1]])), np.arange(2000))
    both = np.concatenate([tris, np.roll(tris[:10], 1, axis=1)])
    assert np.array_equal(dedup.first_of_repeated_corners(both), np.arange(1000))


def test_the_no_cache_flag_writes_nothing(own_cache, monkeypatch):
    from click.testing import CliRunner

    from mcpt.cli.main import main

    monkeypatch.setenv("MCPT_CACHE", "1")  # the flag sets it to 0 in-process; undone after the test
    out = CliRunner().invoke(main, ["info", str(CORNELL), "--no-cache", "--json"])
    assert out.exit_code == 0, out.output
    cache.wait()
    assert not own_cache.exists() and "cache" not in json.loads(out.output)["counts"]
    monkeypatch.setenv("MCPT_CACHE", "1")
    out = CliRunner().invoke(main, ["info", str(CORNELL), "--json"])
    assert json.loads(out.output)["counts"]["cache"] == "miss" and len(entries(own_cache)) == 1


@pytest.mark.parametrize("scene_file", [CORNELL, SPOT_SCENE, ROOT / "scenes" / "sky.yaml"])
def test_cached_packed_buffers_equal_a_fresh_pack(scene_file, own_cache):
    from mcpt.gpu.features import for_world
    from mcpt.gpu.pack import pack
    from mcpt.gpu.pack_cache import cached_pack

    scene = load_scene(scene_file)
    packs = []
    for _ in range(2):  # miss, then hit
        world = cached_world(scene, load_world)
        feats = for_world(world, loop_limit=1000)
        packs.append(cached_pack(world, feats, pack))
    fresh = pack(load_world(scene), feats)
    assert len(entries(own_cache, "packed")) == 1
    for p in packs:
        assert p.buffers.keys() == fresh.buffers.keys()
        for k, v in fresh.buffers.items():
            assert p.buffers[k].dtype == v.dtype and np.array_equal(p.buffers[k], v), k
        assert p.uniforms == fresh.uniforms and p.per_item == fresh.per_item
        assert (p.width, p.height) == (fresh.width, fresh.height)


@pytest.mark.parametrize("text", [
    b"v 1 2 3\nf 1 2 3\n", b"# nan inf e+99\nv 1 2 3\n", b"v 1e-05 2 3\n", b"v 1e38 0 0\n", b"v 1E+40 0 0\n",
    b"v 1 2 3e400\n", b"v nan 0 0 # n\n", b"v 0 0 -inf\n", b"o NaN\nv 1 2 3\n", b"v 1 2 3 # e+40\n",
    b"mtllib a.mtl\nusemtl Inf\nv 1 2 3\n"])
def test_the_quick_scan_for_bad_vertices_finds_what_the_full_scan_finds(text):
    """ObjFile.bad_vertex skips the full scan when no vertex can be bad: same answers."""
    import math
    import re

    from mcpt.shapes.obj import FLOAT32_MAX, ObjFile

    bad = None
    for k, m in enumerate(re.finditer(rb"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", text, re.MULTILINE)):
        xyz = [float(t) for t in m.groups()]
        if not all(math.isfinite(x) and abs(x) <= FLOAT32_MAX for x in xyz):
            bad = k + 1
            break
    found = ObjFile("x.obj", text).bad_vertex()
    assert (found is None) == (bad is None)
    if bad is not None:
        assert f"vertex {bad} is not finite" in found


def test_remembered_file_digests_follow_every_change(tmp_path, own_cache):
    f = tmp_path / "m.obj"
    f.write_bytes(b"v 0 0 0\n")
    os.utime(f, ns=(1_000_000_000_000_000_000, 1_000_000_000_000_000_000))  # long before the record
    first = cache.file_digest(f)
    assert list((own_cache / "digests").glob("*.json"))  # remembered
    assert cache.file_digest(f) == first
    f.write_bytes(b"v 1 0 0\n")  # same size; mtime put back: the ctime still moves
    os.utime(f, ns=(1_000_000_000_000_000_000, 1_000_000_000_000_000_000))
    assert cache.file_digest(f) != first
    assert cache.file_digest(tmp_path / "none.obj") == "missing"


def test_the_setup_benchmark_times_a_cold_miss_then_a_warm_hit(tmp_path):
    from mcpt.bench import setup_speed

    from .conftest import CORNELL_REF

    res = setup_speed.measure(CORNELL_REF, 1, tmp_path, peer=False)
    cold, warm = res["mcpt cold"]["runs"][0], res["mcpt warm"]["runs"][0]
    assert (cold["cache"], warm["cache"]) == ("miss", "hit")
    assert cold["triangles"] == warm["triangles"] == 36
    assert "mcpt cold" in setup_speed.table(res)


def test_an_edited_texture_misses_the_cache(tmp_path, own_cache):
    import cv2

    doc = yaml.safe_load(SPOT_SCENE.read_text())
    for m in doc["meshes"]:
        m["file"] = str(SPOT_SCENE.parent / m["file"])
    image = cv2.imread(str(SPOT_SCENE.parent / doc["materials"]["spot"]["albedo_texture"]["file"]))
    cv2.imwrite(str(tmp_path / "t.png"), image)
    doc["materials"]["spot"]["albedo_texture"]["file"] = str(tmp_path / "t.png")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    a = cached_world(load_scene(tmp_path / "s.yaml"), load_world)
    assert cached_world(load_scene(tmp_path / "s.yaml"), load_world).stats["cache"] == "hit"
    cv2.imwrite(str(tmp_path / "t.png"), 255 - image)
    b = cached_world(load_scene(tmp_path / "s.yaml"), load_world)
    assert b.stats["cache"] == "miss"
    assert not np.array_equal(a.textures[0].srgb, b.textures[0].srgb)
    assert_same_world(b, load_world(load_scene(tmp_path / "s.yaml")))


def test_a_scene_with_every_light_type_is_cached_and_an_edited_environment_map_misses(tmp_path, own_cache):
    """scenes/sky.yaml (an environment map file, a sun) and scenes/lamps.yaml (point and spot)."""
    for name in ("lamps.yaml", "sky.yaml"):
        scene = load_scene(ROOT / "scenes" / name)
        built = load_world(scene)
        cached_world(scene, load_world)
        hit = cached_world(scene, load_world)
        assert hit.stats["cache"] == "hit", name
        assert_same_world(built, hit)
        assert hit.lights.kinds == built.lights.kinds and len(hit.lights.punctual) == len(built.lights.punctual)
        assert np.array_equal(hit.lights.pmf, built.lights.pmf)
        if built.lights.envmap is not None:
            for f in ("texels", "row_q", "row_alias", "col_q", "col_alias", "cell_pdf", "to_world"):
                assert np.array_equal(getattr(hit.lights.envmap, f), getattr(built.lights.envmap, f)), f
    doc = yaml.safe_load((ROOT / "scenes" / "sky.yaml").read_text())
    shutil.copy(ROOT / "scenes" / doc["environment"]["file"], tmp_path / "env.exr")
    doc["environment"]["file"] = str(tmp_path / "env.exr")
    for m in doc["meshes"]:
        if m.get("file"):
            m["file"] = str(ROOT / "scenes" / m["file"])
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    assert cached_world(load_scene(tmp_path / "s.yaml"), load_world).stats["cache"] == "miss"
    assert cached_world(load_scene(tmp_path / "s.yaml"), load_world).stats["cache"] == "hit"
    (tmp_path / "env.exr").write_bytes((tmp_path / "env.exr").read_bytes() + b"\0")  # another file
    assert cached_world(load_scene(tmp_path / "s.yaml"), load_world).stats["cache"] == "miss"


def test_a_flipped_byte_in_any_member_is_refused_with_the_checks_in_threads(own_cache):
    """Members of 4 MiB and more have their CRC-32 checked in threads (mcpt/cache.py _check_crcs):
    a damaged byte in any of them, large or small, still makes the entry a miss."""
    big = 1 << 22
    arrays = {"a": np.arange(big // 4, dtype=np.uint32), "b": np.ones(big // 4 + 5, np.float32),
              "c": np.arange(3, dtype=np.int64)}
    for victim in ("a", "b", "c", None):
        store = cache.Store("crc")
        path = store.put("k" * 64, {"victim": victim}, arrays)
        if victim is not None:
            data = bytearray(path.read_bytes())
            payload = arrays[victim].tobytes()
            at = data.find(payload) + len(payload) // 2  # the middle of that member's payload
            data[at] ^= 0x40
            path.write_bytes(bytes(data))
            assert store.get("k" * 64) is None, victim
        else:
            meta, got = store.get("k" * 64)
            assert all(np.array_equal(got[k], arrays[k]) for k in arrays)


def test_the_worst_sah_cost_is_kept_with_the_cached_world(own_cache):
    """The features' BVH.dense test walks every node; the cached world carries its answer."""
    scene = load_scene(SPOT_SCENE)
    built = cached_world(scene, load_world)
    cache.wait()
    again = cached_world(scene, load_world)
    assert again.stats["cache"] == "hit"
    assert again.bvh.worst_cost is not None
    assert again.bvh.worst_cost == built.bvh.worst_cost == built.bvh._worst_sah_cost()


def test_a_cold_key_reads_each_mesh_file_once(own_cache, monkeypatch):
    """world_key hashes a mesh file and finds the files it names in one read (issue #23: a mesh
    path is also a file the scene names, and was read and hashed a second time for that)."""
    from pathlib import Path

    from mcpt.shapes.world_cache import world_key

    reads: list[str] = []
    real = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda self: reads.append(self.name) or real(self))
    scene = load_scene(CORNELL)
    key = world_key(scene)
    meshes = sorted(Path(m.file).name for m in scene.meshes if m.file)
    assert meshes and sorted(n for n in reads if n.endswith(".obj")) == meshes
    reads.clear()
    assert world_key(scene) == key and reads == []  # remembered: no file read at all
