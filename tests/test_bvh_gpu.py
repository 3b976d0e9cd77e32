"""The GLSL traversal (glsl/bvh.glsl) against the numpy brute-force reference on the bunny."""

import numpy as np

from mcpt.bench.probe import run_probe
from mcpt.shapes.bvh_build import build_bvh
from mcpt.shapes.geometry import pack_triangles
from mcpt.shapes.mesh import load_mesh

from .conftest import SUZANNE, bunny_reference


def _rays(lo, hi, n, rng):
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    d = rng.normal(size=(n, 3))
    origins = centre + radius * d / np.linalg.norm(d, axis=1, keepdims=True)
    targets = lo + rng.random((n, 3)) * (hi - lo)
    dirs = targets - origins
    return origins, dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


def _gpu_closest(gl, tris32, bvh, origins, dirs, use_bvh=True):
    probe = np.zeros((2 * len(origins), 4), np.uint32)
    probe[0::2, :3] = origins.astype(np.float32).view(np.uint32)
    probe[1::2, :3] = dirs.astype(np.float32).view(np.uint32)
    flag = int(use_bvh)
    out = run_probe(gl, "probe_trace.frag", probe, len(origins),
                    preamble=f"#define MCPT_BVH {flag}", key=("bvh", flag),
                    tbos={"nodes": bvh.gpu_nodes(tris32),
                          "tris": pack_triangles(tris32, np.zeros(len(tris32), np.int32))},
                    uniforms={"u_tri_count": len(tris32)})
    t = np.where(out[:, 1] > 0, out[:, 0].view(np.float32), np.inf)
    return t, out[:, 1].astype(np.int64) - 1


def test_gpu_traversal_matches_brute_force_on_the_bunny(gl):
    tris, bvh, origins, dirs, t_ref, tri_ref = bunny_reference()
    tris32 = tris[bvh.order].astype(np.float32)
    t_gpu, tri_gpu = _gpu_closest(gl, tris32, bvh, origins, dirs)
    tri_gpu = np.where(tri_gpu >= 0, bvh.order[np.maximum(tri_gpu, 0)], -1)
    hit = np.isfinite(t_ref)
    assert hit.mean() > 0.4  # the rays really test the mesh
    assert np.array_equal(np.isfinite(t_gpu), hit)
    # The watertight test (GPU) and Moeller-Trumbore (numpy) may pick different triangles only
    # on exact ties at shared edges; nearly all must be the same triangle at the same distance.
    assert (tri_gpu == tri_ref)[hit].mean() > 0.999
    np.testing.assert_allclose(t_gpu[hit], t_ref[hit], rtol=2e-5)


def test_brute_force_shader_path_agrees_with_bvh_path(gl):
    mesh = load_mesh(SUZANNE)
    tris32 = mesh.vertices[mesh.faces].astype(np.float32)
    bvh = build_bvh(tris32)
    tris32 = tris32[bvh.order]
    rng = np.random.default_rng(5)
    lo, hi = tris32.reshape(-1, 3).min(0), tris32.reshape(-1, 3).max(0)
    o, d = _rays(lo.astype(np.float64), hi.astype(np.float64), 3000, rng)
    t1, i1 = _gpu_closest(gl, tris32, bvh, o, d, use_bvh=True)
    t2, i2 = _gpu_closest(gl, tris32, bvh, o, d, use_bvh=False)
    assert np.isfinite(t1).mean() > 0.3
    assert np.array_equal(i1, i2)
    assert np.array_equal(t1, t2)



def _gpu_brute(gl, tris32, origins, dirs, tri_const, shared=False, tmax=None):
    """``shared``: False, True (distinct vertices fetched once, edges shared) or "compiled"
    (their positions compiled in, issue #23). ``tmax``: (R,) segment lengths: the shadow-ray
    query visible() instead (column 0: 1 visible, 0 blocked)."""
    from mcpt.gpu.features import vertex_tables
    from mcpt.shapes.geometry import shared_vertices, vertex_bits

    probe = np.zeros((2 * len(origins), 4), np.uint32)
    probe[0::2, :3] = origins.astype(np.float32).view(np.uint32)
    probe[1::2, :3] = dirs.astype(np.float32).view(np.uint32)
    preamble = f"#define MCPT_BVH 0\n#define MCPT_TRI_CONST {tri_const}"
    if tmax is not None:
        probe[0::2, 3] = np.asarray(tmax, np.float32).view(np.uint32)
        preamble += "\n#define PROBE_VISIBLE 1"
    if shared:
        addr, ids = shared_vertices(tris32)
        pos = vertex_bits(tris32, addr) if shared == "compiled" else ()
        preamble += f"\n#define MCPT_VERT_COUNT {len(addr)}\n" + vertex_tables(addr, ids.ravel(), pos)
    return run_probe(gl, "probe_trace.frag", probe, len(origins), preamble=preamble,
                     key=("brute", tri_const, preamble),
                     tbos={"tris": pack_triangles(tris32, np.zeros(len(tris32), np.int32))},
                     uniforms={"u_tri_count": len(tris32)})


def test_shared_vertices_index_the_same_corners():
    from mcpt.shapes.geometry import shared_vertices

    mesh = load_mesh(SUZANNE)
    tris = mesh.vertices[mesh.faces[:40]].astype(np.float32)
    addr, ids = shared_vertices(tris)
    corners = tris.reshape(-1, 3)
    assert len(addr) < 3 * len(tris)  # neighbouring faces share corners
    assert np.array_equal(corners[addr][ids].reshape(tris.shape).view(np.uint32), tris.view(np.uint32))
    assert np.array_equal(addr, np.sort(addr))  # numbered by first appearance


def test_written_out_brute_force_agrees_bitwise(gl):
    """glsl/bvh.glsl MCPT_TRI_CONST (small scenes, the loop written out, with and without the
    once-per-ray shear of shared vertices) finds the same hit, bit for bit, as the u_tri_count
    loop, for counts inside, at and past its groups of 4 and 16."""
    from mcpt.gpu.features import TRI_CONST_MAX
    mesh = load_mesh(SUZANNE)
    all_tris = mesh.vertices[mesh.faces].astype(np.float32)
    rng = np.random.default_rng(11)
    for n in (1, 3, 17, 36, TRI_CONST_MAX):
        start = int(rng.integers(0, len(all_tris) - n))
        tris32 = all_tris[start:start + n]  # consecutive faces: neighbours, shared corners
        # Rays from a sphere around the triangles towards random points on them, so most hit;
        # many pass near shared edges and vertices.
        w = rng.dirichlet((1, 1, 1), 2000)
        targets = np.einsum("nk,nkj->nj", w, tris32[rng.integers(0, n, 2000)].astype(np.float64))
        o = rng.normal(size=(2000, 3))
        o = targets.mean(0) + 3.0 * o / np.linalg.norm(o, axis=1, keepdims=True)
        d = (targets - o) / np.linalg.norm(targets - o, axis=1, keepdims=True)
        loop = _gpu_brute(gl, tris32, o, d, 0)
        assert (loop[:, 1] > 0).mean() > 0.5, n  # the rays really hit something
        for shared in (False, True, "compiled"):
            assert np.array_equal(loop, _gpu_brute(gl, tris32, o, d, n, shared)), (n, shared)


def test_written_out_shadow_rays_agree_with_the_loop(gl):
    """The written-out triangles' shadow-ray test (glsl/geometry.glsl edges_block: t in (0, tmax)
    decided without the division, no hit record; issue #23) blocks exactly the segments the
    u_tri_count loop's any-hit test blocks: segments ending well before, just before, just past
    and well past the closest hit, and rays that hit nothing."""
    mesh = load_mesh(SUZANNE)
    all_tris = mesh.vertices[mesh.faces].astype(np.float32)
    rng = np.random.default_rng(12)
    for n in (3, 36):
        start = int(rng.integers(0, len(all_tris) - n))
        tris32 = all_tris[start:start + n]
        w = rng.dirichlet((1, 1, 1), 1500)
        targets = np.einsum("nk,nkj->nj", w, tris32[rng.integers(0, n, 1500)].astype(np.float64))
        o = rng.normal(size=(1500, 3))
        o = targets.mean(0) + 3.0 * o / np.linalg.norm(o, axis=1, keepdims=True)
        d = (targets - o) / np.linalg.norm(targets - o, axis=1, keepdims=True)
        d[:300] *= -1.0  # away from the triangles: no hit
        closest = _gpu_brute(gl, tris32, o, d, 0)
        t_hit = np.where(closest[:, 1] > 0, closest[:, 0].view(np.float32), 5.0)
        assert 0.5 < (closest[:, 1] > 0).mean() < 0.85, n
        for scale in (0.5, 0.999, 1.001, 2.0, np.inf):
            tmax = t_hit * scale
            loop = _gpu_brute(gl, tris32, o, d, 0, tmax=tmax)[:, 0]
            written = _gpu_brute(gl, tris32, o, d, n, "compiled", tmax=tmax)[:, 0]
            # Blocked iff a hit lies before tmax: nothing blocks short segments, a hit blocks long ones.
            assert loop[closest[:, 1] == 0].all() and (loop[closest[:, 1] > 0] == (scale < 1.0)).all(), scale
            assert np.array_equal(loop, written), (n, scale)


def test_shared_edges_give_each_side_its_edge_function():
    """mcpt/shapes/geometry.py shared_edges (issue #23): every side of every triangle refers to
    one distinct undirected edge, with the sign that turns e(lo, hi) into the side's own
    e(P, Q) (U = e(C, B), V = e(A, C), W = e(B, A)); a closed mesh has half as many edges as
    sides; vertex_bits gives the distinct vertices' exact float32 bits."""
    from mcpt.shapes.geometry import shared_edges, shared_vertices, vertex_bits

    mesh = load_mesh(SUZANNE)
    tris = mesh.vertices[mesh.faces[:60]].astype(np.float32)
    addr, ids = shared_vertices(tris)
    edges, signed = shared_edges(ids)
    assert signed.shape == ids.shape and len(edges) < 3 * len(ids)  # neighbours share edges
    assert np.all(edges[:, 0] <= edges[:, 1]) and len(np.unique(edges, axis=0)) == len(edges)
    sides = np.stack([ids[:, [2, 0, 1]], ids[:, [1, 2, 0]]], axis=-1)  # (P, Q) of U, V, W
    k = np.where(signed >= 0, signed, ~signed)
    lo_hi = edges[k]
    forward = (lo_hi[..., 0] == sides[..., 0]) & (lo_hi[..., 1] == sides[..., 1])
    backward = (lo_hi[..., 0] == sides[..., 1]) & (lo_hi[..., 1] == sides[..., 0])
    assert np.all(np.where(signed >= 0, forward, backward & (sides[..., 0] != sides[..., 1])))
    cube = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    assert len(shared_edges(cube)[0]) == 18  # closed: 36 sides, each edge twice
    bits = np.array(vertex_bits(tris, addr), np.uint32).reshape(-1, 3)
    assert np.array_equal(bits, tris.reshape(-1, 3)[addr].view(np.uint32))


def test_vertex_tables_count_the_fetches_they_make():
    """The counters' fetches per ray (TRI_VERT_FETCHES): one texel a distinct vertex when the
    positions are fetched, none when their bits are compiled in (a lambda once shadowed the
    positions' name, so fetched tables counted none)."""
    from mcpt.gpu.features import vertex_tables
    from mcpt.shapes.geometry import shared_vertices, vertex_bits

    tris = load_mesh(SUZANNE).vertices[load_mesh(SUZANNE).faces[:20]].astype(np.float32)
    addr, ids = shared_vertices(tris)
    fetched = vertex_tables(addr, ids.ravel())
    compiled = vertex_tables(addr, ids.ravel(), vertex_bits(tris, addr))
    assert f"#define TRI_VERT_FETCHES {len(addr)}\n" in fetched and fetched.count("texelFetch(u_tris") == len(addr)
    assert "#define TRI_VERT_FETCHES 0\n" in compiled and "texelFetch" not in compiled


def test_large_triangles_tested_first_give_the_same_hits(gl):
    """A mesh inside a box of large triangles: build_bvh puts the box in the root's right
    subtree; testing it written out first and traversing from the root's left child
    (MCPT_BVH_START, bvh.py large_tail) finds the same hits as traversing the whole tree."""
    from mcpt.gpu.features import vertex_tables
    from mcpt.shapes.geometry import shared_vertices

    mesh = load_mesh(SUZANNE)
    inner = mesh.vertices[mesh.faces].astype(np.float64)
    lo, hi = inner.reshape(-1, 3).min(0) - 0.5, inner.reshape(-1, 3).max(0) + 0.5
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    box = np.array([c[list(t)] for a, b, cc, d in quads for t in ((a, b, cc), (a, cc, d))])
    tris32 = np.concatenate([inner, box]).astype(np.float32)
    bvh = build_bvh(tris32)
    tris32 = tris32[bvh.order]
    first, start = bvh.large_tail()
    assert len(tris32) - first == len(box) and start > 0
    addr, ids = shared_vertices(tris32[first:])
    rng = np.random.default_rng(3)
    n = 4000
    o = lo + rng.random((n, 3)) * (hi - lo)  # inside the box: every ray hits something
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    probe = np.zeros((2 * n, 4), np.uint32)
    probe[0::2, :3] = o.astype(np.float32).view(np.uint32)
    probe[1::2, :3] = d.astype(np.float32).view(np.uint32)
    tbos = {"nodes": bvh.gpu_nodes(tris32), "tris": pack_triangles(tris32, np.zeros(len(tris32), np.int32))}
    plain = run_probe(gl, "probe_trace.frag", probe, n, preamble="#define MCPT_BVH 1",
                      key=("bvh", 1), tbos=tbos, uniforms={"u_tri_count": len(tris32)})
    pre = (f"#define MCPT_BVH 1\n#define MCPT_TRI_CONST {len(box)}\n#define MCPT_TRI_FIRST {first}\n"
           f"#define MCPT_BVH_START {start}\n#define MCPT_VERT_COUNT {len(addr)}\n"
           + vertex_tables(addr + 3 * first, ids.ravel()))
    tail = run_probe(gl, "probe_trace.frag", probe, n, preamble=pre, key=("bvh-tail", pre),
                     tbos=tbos, uniforms={"u_tri_count": len(tris32)})
    assert (plain[:, 1] > 0).all()
    assert (plain[:, 1] - 1 >= first).mean() > 0.3  # many rays end on the box
    assert np.array_equal(plain[:, 0], tail[:, 0])  # the same distances
    assert (plain == tail).all(axis=1).mean() > 0.999  # the same triangles but on exact ties
