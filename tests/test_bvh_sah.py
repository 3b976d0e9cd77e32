"""The SAH-chosen median tree (mcpt/bvh.py), its GPU buffer, and the traversal counters."""

from __future__ import annotations

import numpy as np
import pytest

from mcpt.shapes.bvh import GPU_COUNT_SHIFT, SAH_STEP_COST, SAH_TRI_COST
from mcpt.shapes.bvh_build import build_bvh
from mcpt.shapes.mesh import load_mesh

from .conftest import BUNNY, CORNELL, ROOT
from .merge import merge_meshes
from .oracles import brute_force_closest_hit, bvh_closest_hit
from .test_bvh import check_invariants, random_triangles


def _meshes():
    rng = np.random.default_rng(7)
    stretched = random_triangles(rng, 3000)
    stretched[:, :, 1] *= 10.0
    slivers = rng.random((2000, 1, 3)) + np.array([[0, 0, 0], [0.3, 0, 0], [0, 0.001, 0]])
    bunny = load_mesh(BUNNY).triangles()
    cornell = merge_meshes([(load_mesh(p), None) for p in sorted(CORNELL.glob("*.obj"))])
    box_and_bunny = np.concatenate([cornell.triangles(), bunny * 7.0])
    return {"random": random_triangles(rng, 5000), "stretched": stretched, "slivers": slivers,
            "bunny": bunny, "cornell+bunny": box_and_bunny}


MESHES = _meshes()


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("max_leaf", [1, 4])
def test_sah_cost_never_worse_than_longest_axis_median(name, max_leaf):
    tris = MESHES[name]
    sah = build_bvh(tris, max_leaf=max_leaf)
    longest = build_bvh(tris, max_leaf=max_leaf, sah=False)
    longest_1 = build_bvh(tris, max_leaf=1, sah=False)
    assert sah.sah_cost() <= longest.sah_cost() * (1 + 1e-9)
    assert sah.sah_cost() <= longest_1.sah_cost() * (1 + 1e-9)
    check_invariants(sah, tris, max_leaf)  # every triangle in exactly one leaf, leaves <= cap


def test_sah_improves_the_bunny_by_a_real_margin():
    bunny = MESHES["bunny"]
    assert build_bvh(bunny).sah_cost() < 0.93 * build_bvh(bunny, max_leaf=1, sah=False).sah_cost()


def test_sah_keeps_a_quad_as_one_leaf_and_splits_distant_triangles():
    quad = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    # Same box for both: a leaf costs 2 tests, a split 1 step + 2 tests.
    b = build_bvh(quad, max_leaf=4)
    assert b.num_nodes == 1 and b.leaf_count[0] == 2
    assert build_bvh(quad, max_leaf=1).leaf_count.max() == 1  # the cap wins over SAH
    # Two tiny triangles far apart: a split enters at most one of two tiny boxes.
    far = np.concatenate([quad[:1] * 1e-3, quad[:1] * 1e-3 + 10.0])
    b = build_bvh(far, max_leaf=4)
    assert b.num_nodes == 3 and b.leaf_count.max() == 1


def test_sah_cost_by_hand():
    # Root box 1 x 1 x 1 (half area 3) over two unit-size leaves of one triangle each.
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 0, 1], [0, 1, 1]]], float)
    b = build_bvh(tris, max_leaf=1)
    assert b.num_nodes == 3
    # Each leaf box is 1 x 1 x 0: half area 1. Cost = step + 2 * (1 / 3) * tri.
    assert b.sah_cost() == pytest.approx(SAH_STEP_COST + 2.0 / 3.0 * SAH_TRI_COST, rel=1e-6)


@pytest.mark.parametrize("name", ["slivers", "cornell+bunny"])
def test_sah_tree_hits_match_brute_force(name):
    tris = MESHES[name]
    rng = np.random.default_rng(3)
    lo, hi = tris.min(axis=(0, 1)), tris.max(axis=(0, 1))
    o = lo + rng.random((1500, 3)) * (hi - lo)
    d = rng.standard_normal((1500, 3))
    bvh = build_bvh(tris)
    t_ref, i_ref = brute_force_closest_hit(tris, o, d)
    t, i = bvh_closest_hit(bvh, tris[bvh.order], o, d)
    assert np.array_equal(np.where(i >= 0, bvh.order[np.maximum(i, 0)], -1), i_ref)
    np.testing.assert_array_equal(t, t_ref)


def test_gpu_buffer_references_every_triangle_once():
    tris = MESHES["random"].astype(np.float32)
    bvh = build_bvh(tris)
    tr = tris[bvh.order]
    buf = bvh.gpu_nodes(tr)
    n_int = int((~bvh.is_leaf).sum())
    assert buf.shape == (4 * n_int + 3 * len(tris) + 1, 4)
    # Walk the references from the root (texel 0): every record is reached exactly once, the
    # records tile the buffer, and a node's near child follows it (depth-first order, each
    # leaf's triangle records where the leaf stands in it: issue #23, memory locality).
    owner = np.full(len(buf), -1, np.int64)
    seen, stack = [], [0]
    while stack:
        ref = stack.pop()
        count, addr = ref >> GPU_COUNT_SHIFT, ref & ((1 << GPU_COUNT_SHIFT) - 1)
        span = 4 if count == 0 else 3 * count
        assert (owner[addr:addr + span] < 0).all()
        owner[addr:addr + span] = addr
        if count:
            rec = buf[addr:addr + span].reshape(count, 3, 4)
            j = rec[:, 0, 3].astype(np.int64)
            seen.extend(j)
            assert np.array_equal(rec[:, :, :3].view(np.float32), tr[j])
            assert not rec[:, 1:, 3].any()
        else:
            left, right = int(buf[addr, 3]), int(buf[addr + 2, 3])
            assert left & ((1 << GPU_COUNT_SHIFT) - 1) == addr + 4
            stack += [right, left]
    assert (owner[:-1] >= 0).all() and owner[-1] < 0  # one pad texel after the records
    assert np.array_equal(np.sort(seen), np.arange(len(tris)))


def test_counters_are_compiled_out_by_default_and_add_up(gl):
    from mcpt.bench.counters import measure
    from mcpt.gpu.features import Features
    from mcpt.gpu.shader import Source
    plain = Source("pathtrace.frag", Features.of(bounces=2).preamble()).text
    assert "atomicAdd" not in plain
    m = measure(ROOT / "scenes" / "bunny-metal.yaml", resolution=(32, 32), bounces=2)
    assert m["bvh"] and m["rays"] >= 32 * 32 and 0 < m["shadow_rays"] < m["rays"]
    # One loop iteration is one node step or one triangle test, each reading four texels; the
    # large triangles tested written out before the traversal (glsl/bvh.glsl trace_const) add
    # their tests to every ray, no iterations and no fetches: their distinct vertices' positions
    # are compiled in (issue #23).
    from mcpt.gpu.features import for_world
    from mcpt.scene import load_scene
    from mcpt.shapes.world import load_world
    f = for_world(load_world(load_scene(ROOT / "scenes" / "bunny-metal.yaml")), bounces=2)
    d = f.defines()
    tail, verts = d["MCPT_TRI_CONST"], d["MCPT_VERT_COUNT"]
    assert tail > 0 and 0 < verts <= 3 * tail  # the bunny sits in a box of large triangles
    assert len(f.compiled.vert_pos) == 3 * verts and "#define TRI_VERT_FETCHES 0" in f.preamble()
    assert f.preamble().count("tri_shear(r, p, uintBitsToFloat(uvec3(") == verts
    loop_tris = m["triangle_tests_per_ray"] - tail
    assert m["iterations_per_ray"] == pytest.approx(m["node_steps_per_ray"] + loop_tris)
    assert m["fetches_per_ray"] == pytest.approx(4 * m["iterations_per_ray"])
    assert 1.0 <= m["node_steps_per_ray"] < 60.0


def test_lane_utilization_counts_the_batches_slowest_lane(gl, tmp_path):
    """The counters' SIMD view (issue #23): a batch runs the traversal loop while any of its lanes
    needs it. With the same work on every lane (no BVH: every ray tests every triangle, camera
    rays only) the lane slots are all used but for the few batches llvmpipe runs part-filled at
    tile edges; a BVH, where rays take different paths, leaves most slots idle."""
    from mcpt.bench.counters import measure
    if "GL_ARB_shader_ballot" not in gl.ctx.extensions:
        pytest.skip("the driver counts no SIMD batches (no GL_ARB_shader_ballot)")
    rng = np.random.default_rng(1)
    corners = rng.uniform([-0.5, 0.2, -0.5], [0.5, 1.5, 0.5], (60, 1, 3)) + [[0, 0, 0], [0.02, 0, 0], [0, 0.02, 0]]
    (tmp_path / "bits.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners.reshape(-1, 3))
                                       + "".join(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n" for i in range(60)))
    scene = (ROOT / "scenes" / "cornell-box.yaml").read_text().replace("file: cornell/", f"file: {CORNELL}/")
    (tmp_path / "s.yaml").write_text(scene + f"  - file: {tmp_path / 'bits.obj'}\n    material: white\n")
    same = measure(tmp_path / "s.yaml", resolution=(256, 256), bounces=0, feature_flags={"bvh": False})
    assert not same["bvh"] and same["shadow_rays"] == 0
    assert same["iterations_per_ray"] == 24  # 96 triangles, 4 an iteration (glsl/bvh.glsl trace_brute)
    assert same["batch_lanes"] >= 4 and 0.95 < same["lane_utilization"] <= 1.0
    varied = measure(ROOT / "scenes" / "bunny-metal.yaml", resolution=(64, 64), bounces=2)
    assert varied["bvh"] and varied["batch_lanes"] == same["batch_lanes"]
    assert varied["lane_utilization"] < 0.6
    assert varied["batch_iterations_per_ray"] * varied["batch_lanes"] > varied["iterations_per_ray"] / 0.6


def test_large_meshes_fall_back_to_the_longest_axis_median(monkeypatch):
    import mcpt.shapes.bvh_build as bvh_mod

    tris = MESHES["random"]
    monkeypatch.setattr(bvh_mod, "SAH_MAX_TRIANGLES", len(tris) - 1)
    big = build_bvh(tris, max_leaf=4)
    plain = build_bvh(tris, max_leaf=4, sah=False)
    assert np.array_equal(big.nodes, plain.nodes) and np.array_equal(big.order, plain.order)


def test_dense_trees_are_detected_even_inside_a_larger_scene():
    from mcpt.bench.stability.geometry import star_cluster

    v, f = star_cluster(10_000)  # 10^4 triangles whose boxes all overlap
    wall = np.array([[[-9, -9, -5], [9, -9, -5], [9, 9, -5]], [[-9, -9, -5], [9, 9, -5], [-9, 9, -5]]], float)
    scene = build_bvh(np.concatenate([v[f], wall]))
    assert scene.sah_cost() < scene.worst_sah_cost()
    assert scene.dense and build_bvh(v[f]).dense
    assert not build_bvh(MESHES["bunny"]).dense and not build_bvh(MESHES["cornell+bunny"]).dense


def test_dense_traversal_agrees_with_the_default_one(gl):
    from mcpt.bench.probe import run_probe
    from mcpt.shapes.geometry import pack_triangles

    tris = MESHES["cornell+bunny"].astype(np.float32)
    bvh = build_bvh(tris)
    tr = tris[bvh.order]
    rng = np.random.default_rng(9)
    lo, hi = tr.reshape(-1, 3).min(0), tr.reshape(-1, 3).max(0)
    o = lo + (0.1 + 0.8 * rng.random((3000, 3))) * (hi - lo)
    d = rng.standard_normal((3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    probe = np.zeros((2 * len(o), 4), np.uint32)
    probe[0::2, :3] = o.astype(np.float32).view(np.uint32)
    probe[1::2, :3] = d.astype(np.float32).view(np.uint32)
    outs = []
    for dense in (0, 1):
        outs.append(run_probe(gl, "probe_trace.frag", probe, len(o),
                              preamble=f"#define MCPT_BVH 1\n#define MCPT_BVH_DENSE {dense}",
                              key=("bvh-dense", dense),
                              tbos={"nodes": bvh.gpu_nodes(tr, dense=bool(dense)),
                                    "tris": pack_triangles(tr, np.zeros(len(tr), np.int32))},
                              uniforms={"u_tri_count": len(tr)}))
    assert (outs[0][:, 1] > 0).mean() > 0.7
    assert np.array_equal(outs[0], outs[1])
