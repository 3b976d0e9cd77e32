// Closest-hit and any-hit traversal (host side: mcpt/shapes/bvh.py BVH.gpu_nodes defines the layout).
// One RGBA32UI buffer holds interior nodes (4 texels: both children's boxes and references)
//   (left.bmin, left.ref), (left.bmax, 0), (right.bmin, right.ref), (right.bmax, 0)
// and triangle records (3 texels: (v0, triangle index), (v1, 0), (v2, 0)) in the tree's depth-first
// order, a leaf's triangles where the leaf stands, then one pad texel.
#include "geometry.glsl"

layout(binding = 1) uniform usamplerBuffer u_nodes;
#define BVH_STACK 64   // >= tree depth + 2, asserted by the builder (mcpt/shapes/bvh.py MAX_STACK)
#define BVH_MAX_LEAF 4 // triangles per iteration of the brute-force loop (no BVH)
const uint BVH_ADDR_MASK = 0x0fffffffu;  // item reference: texel address in the low 28 bits
const uint BVH_LEAF_ONE = 0x10000000u;   // ... and the leaf's triangle count above them

#ifndef MCPT_COUNTERS
#define MCPT_COUNTERS 0
#endif
#ifndef MCPT_BVH_DENSE
#define MCPT_BVH_DENSE 0
#endif
#ifndef MCPT_TRI_CONST
#define MCPT_TRI_CONST 0
#endif
#ifndef MCPT_VERT_COUNT
#define MCPT_VERT_COUNT 0
#endif
#ifndef MCPT_TRI_FIRST
#define MCPT_TRI_FIRST 0
#endif
// Debug counters (MCPT_COUNTERS, bench/counters.py): per-ray work, summed by atomics.
#if MCPT_COUNTERS
layout(std430, binding = 1) buffer BvhCounters {
    uint c_rays, c_iterations, c_fetches, c_nodes, c_tris, c_shadow, c_batch, c_lanes;
};
uint g_iter = 0u, g_fetch = 0u, g_node = 0u, g_tri = 0u;
float g_batch = 0.0;
#ifdef GL_ARB_shader_ballot
// SIMD batch iterations (issue #23): llvmpipe (and a GPU warp) runs a loop for all lanes of a batch
// while any lane needs it, so a traversal costs its batch's slowest lane. Each active lane adds
// 1 / (active lanes) per iteration: a batch's lanes add up to one per iteration the batch ran, and
// iterations / (lanes x batch iterations) is the share of lane slots doing work (bench/counters.py).
// The extension is enabled in the counters build only (mcpt/gpu/features.py preamble).
float batch_share() {
    uvec2 b = unpackUint2x32(ballotARB(true));
    return 1.0 / float(bitCount(b.x) + bitCount(b.y));
}
#define BATCH_LANES gl_SubGroupSizeARB
#else
float batch_share() { return 0.0; }  // no ballot: no batch count (reported as unknown)
#define BATCH_LANES 0u
#endif
#define BVH_COUNT(it, f) (g_iter += uint(it), g_fetch += uint(f), g_batch += (it) > 0 ? batch_share() : 0.0)
#define BVH_COUNT_NODE() (g_node++)
#define BVH_COUNT_TRIS(n) (g_tri += uint(n))
#else
#define BVH_COUNT(it, f)
#define BVH_COUNT_NODE()
#define BVH_COUNT_TRIS(n)
#endif

// Slab test. Zero direction components are replaced by a tiny value upstream (safe_inv) so no
// 0 * inf = NaN appears; the far distance is widened by 2 gamma(3) (Ize 2013, "Robust BVH Ray
// Traversal") so rounding never misses a box the ray really enters. A ray running exactly along
// a box face (flat boxes of axis-aligned walls) is inside the slab because the host grew every
// box outward (mcpt/shapes/bvh.py grown_boxes; issue #6, case watertight-flat-grid-axis-rays).
bool box_hit(vec3 bmin, vec3 bmax, vec3 o, vec3 inv, float tmax, out float tnear) {
    vec3 t0 = (bmin - o) * inv;
    vec3 t1 = (bmax - o) * inv;
    vec3 tsm = min(t0, t1);
    vec3 tbg = max(t0, t1);
    float tn = max(max(tsm.x, tsm.y), max(tsm.z, 0.0));
    float tf = min(min(tbg.x, tbg.y), min(tbg.z, tmax)) * 1.0000004;
    tnear = tn;
    return tn <= tf;
}

vec3 safe_inv(vec3 d) {
    const float TINY = 1e-30;
    return 1.0 / vec3(abs(d.x) < TINY ? (d.x < 0.0 ? -TINY : TINY) : d.x,
                      abs(d.y) < TINY ? (d.y < 0.0 ? -TINY : TINY) : d.y,
                      abs(d.z) < TINY ? (d.z < 0.0 ? -TINY : TINY) : d.z);
}

// Triangles first .. first + count - 1 (count <= BVH_MAX_LEAF), written out rather than looped:
// a leaf then costs no loop iterations (llvmpipe limits them, see common.glsl).
bool leaf_hit(Ray r, RayPre p, int first, int count, bool any_hit, inout Hit h) {
    bool found = false;
    float t; vec2 bary;
#define LEAF_TRI(k) \
    if (count > k && intersect_tri(r, p, first + k, h.t, t, bary)) { \
        h.t = t; h.tri = first + k; h.bary = bary; found = true; \
        if (any_hit) return true; \
    }
    LEAF_TRI(0)
    LEAF_TRI(1)
    LEAF_TRI(2)
    LEAF_TRI(3)
#undef LEAF_TRI
    return found;
}

#if MCPT_TRI_CONST > 0
// Triangles MCPT_TRI_FIRST .. + MCPT_TRI_CONST - 1, the loop written out: a small scene's
// brute force, or with a BVH the large triangles of the root's right subtree (build_bvh puts them
// there: the walls around a dense mesh), tested before the traversal of the rest (measured
// 1.36-1.42x paths/s on the 100k-triangle sphere in the Cornell box: those triangles are few,
// but a traversal reaches them through many loop iterations).
bool trace_const(Ray r, RayPre p, bool any_hit, inout Hit h) {
    bool found = false;
    // The triangle count compiled in (features.py TRI_CONST_MAX): the loop is written out in
    // full, every triangle at a constant address: 1.32-1.45x the paths/s of the u_tri_count
    // loop (trace) on the Cornell box (issue #14; no loop, no per-group count checks),
    // and with each distinct vertex sheared once (below) 1.5x more again, 2.2x in all. Same
    // triangles, same order, same test: the same hits. (Reading the triangles from a uniform
    // array instead of u_tris measured slower; bench/ab.py.)
#if MCPT_VERT_COUNT > 0
    // Each distinct vertex is loaded and sheared once per ray, not once per triangle using it
    // (the Cornell box: 36 triangles, 108 corners, 28 vertices), its float32 bits compiled in: no
    // texel fetch (issue #23: with the shared edges, 1.21x paths per CPU-second on the Cornell
    // box, 1.11x on the 100k sphere's written-out walls; bench/ab.py --cpu). The shear is a
    // function of the vertex alone, computed exactly as intersect_tri_verts does: same bits, so
    // the test stays watertight and finds the same hits. Then each distinct edge's function once
    // (58 edges for the 108 triangle sides; a negation is exact, so the same U, V, W), then the
    // triangles in order. The code is written by the host (mcpt/gpu/limits.py vertex_tables).
    vec3 tv[MCPT_VERT_COUNT];
    float te[TRI_EDGE_COUNT];
    bool tn[TRI_EDGE_COUNT], tp[TRI_EDGE_COUNT];
    TRI_CONST_VERTS
    TRI_CONST_EDGES
    // Counters: no loop iterations, the vertices' fetches (none when compiled in), every triangle.
    BVH_COUNT(0, TRI_VERT_FETCHES);
    BVH_COUNT_TRIS(MCPT_TRI_CONST);
    // llvmpipe runs every test's code for every ray (issue #14), so what a test computes is what
    // a ray costs: a shadow ray asks only whether some triangle blocks it (no division, no hit
    // record: geometry.glsl edges_block), and the closest hit divides once, after the tests
    // (edges_closer). Issue #23: 1.18x paths per CPU-second on the Cornell box (bench/ab.py
    // --cpu), the same pixels (cut-outs keep the record: opacity.glsl reads the hit).
#if !MCPT_OPACITY
    if (any_hit) {  // a shadow ray (visible()): whether any triangle blocks it
#define TRI_CONST_TEST(idx, U, V, W, Az, Bz, Cz, OUT) if (edges_block(OUT, U, V, W, Az, Bz, Cz, h.t)) found = true;
        TRI_CONST_TESTS
#undef TRI_CONST_TEST
        return found;
    }
#endif
    // The closest hit, its division deferred: the best so far kept as (T, det, V, W) with det's
    // sign folded in (geometry.glsl edges_closer), one division after all the tests.
    float bT = h.t, bD = 1.0;
    vec2 bB = vec2(0.0);
    int bI = -1;
#define TRI_CONST_TEST(idx, U, V, W, Az, Bz, Cz, OUT) edges_closer(OUT, U, V, W, Az, Bz, Cz, idx, bT, bD, bB, bI);
    TRI_CONST_TESTS
#undef TRI_CONST_TEST
    if (bI < 0) return false;
    // T s * (1 / (det s)) is T * (1 / det) exactly (sign flips are exact): the bits of
    // intersect_edges, which the other traversals use.
    float inv = 1.0 / bD;
    h.t = bT * inv; h.bary = bB * inv; h.tri = MCPT_TRI_FIRST + bI;
    return true;
#else
#define TRI_CONST_TEST(idx) \
    if ((idx) < MCPT_TRI_CONST) {  /* a constant: folded away past the count */ \
        float t; vec2 bary; \
        if (intersect_tri(r, p, MCPT_TRI_FIRST + (idx), h.t, t, bary)) { \
            h.t = t; h.tri = MCPT_TRI_FIRST + (idx); h.bary = bary; found = true; \
            if (any_hit) return true; \
        } \
    }
#define TRI_CONST_TEST4(k) TRI_CONST_TEST(k) TRI_CONST_TEST(k + 1) TRI_CONST_TEST(k + 2) TRI_CONST_TEST(k + 3)
#define TRI_CONST_TEST16(k) TRI_CONST_TEST4(k) TRI_CONST_TEST4(k + 4) TRI_CONST_TEST4(k + 8) TRI_CONST_TEST4(k + 12)
    // Counters: no loop iterations, a fetch per corner, every triangle.
    BVH_COUNT(0, 3 * MCPT_TRI_CONST);
    BVH_COUNT_TRIS(MCPT_TRI_CONST);
    TRI_CONST_TEST16(0) TRI_CONST_TEST16(16) TRI_CONST_TEST16(32) TRI_CONST_TEST16(48)  // TRI_CONST_MAX
#undef TRI_CONST_TEST16
#undef TRI_CONST_TEST4
#undef TRI_CONST_TEST
#endif
    return found;
}
#endif

#if MCPT_BVH && MCPT_BVH_DENSE
// Scenes where a ray must test very many triangles (heavily overlapping boxes, mcpt/shapes/bvh.py
// BVH.dense): one triangle per iteration would run into llvmpipe's loop limit
// (common.glsl), so each node step tests both children's boxes and intersects leaf children
// right there, up to 2 x BVH_MAX_LEAF triangles per iteration. Interior node = 4 texels:
//   (left.bmin, left.a), (left.bmax, left.b), (right.bmin, right.a), (right.bmax, right.b)
// child b == 0: interior node a; else leaf with first triangle a, count b & 0x7fffffff.
bool trace_dense(Ray r, RayPre p, inout Hit h, bool any_hit) {
    bool found = false;
    vec3 inv = safe_inv(r.d);
    int stack[BVH_STACK];
    int sp = 0;
    int node = 0;
    while (true) {
        LOOP_TICK();
        uvec4 l0 = texelFetch(u_nodes, 4 * node);
        uvec4 l1 = texelFetch(u_nodes, 4 * node + 1);
        uvec4 r0 = texelFetch(u_nodes, 4 * node + 2);
        uvec4 r1 = texelFetch(u_nodes, 4 * node + 3);
        BVH_COUNT(1, 4 + 6 * BVH_MAX_LEAF);  // all code runs under the mask (issue #14)
        BVH_COUNT_NODE();
        BVH_COUNT_TRIS(2 * BVH_MAX_LEAF);
        float tl, tr;
        bool hl = box_hit(uintBitsToFloat(l0.xyz), uintBitsToFloat(l1.xyz), r.o, inv, h.t, tl);
        bool hr = box_hit(uintBitsToFloat(r0.xyz), uintBitsToFloat(r1.xyz), r.o, inv, h.t, tr);
        if (hl && l1.w != 0u && leaf_hit(r, p, int(l0.w), int(l1.w & 0x7fffffffu), any_hit, h)) {
            found = true;
            if (any_hit) return true;
        }
        if (hr && r1.w != 0u && leaf_hit(r, p, int(r0.w), int(r1.w & 0x7fffffffu), any_hit, h)) {
            found = true;
            if (any_hit) return true;
        }
        hl = hl && l1.w == 0u;
        hr = hr && r1.w == 0u;
        if (hl && hr) {
            bool left_first = tl <= tr;
            stack[sp++] = int(left_first ? r0.w : l0.w);
            node = int(left_first ? l0.w : r0.w);
        } else if (hl) {
            node = int(l0.w);
        } else if (hr) {
            node = int(r0.w);
        } else {
            if (sp == 0) break;
            node = stack[--sp];
        }
    }
    return found;
}

#elif MCPT_BVH
// One loop iteration = one work item, a node OR one triangle, read with the same four fetches:
// llvmpipe runs the whole loop body for every lane whatever each lane needs (issue #14), so the
// body holds one box-pair test, one triangle test and four texel fetches, nothing more.
// Item reference: texel address | triangle count << 28; count 0 is a node, count k >= 1 the
// leaf of k consecutive triangle records starting there (a leaf cursor: one triangle per step).
bool trace_bvh(Ray r, RayPre p, inout Hit h, bool any_hit) {
    bool found = false;
    vec3 inv = safe_inv(r.d);
    uint stack[BVH_STACK];
    int sp = 0;
#if MCPT_TRI_CONST > 0
    // The large triangles first, then the rest of the tree: the root's left child.
    found = trace_const(r, p, any_hit, h);
    if (any_hit && found) return true;
    uint cur = uint(MCPT_BVH_START);
#else
    uint cur = 0u;  // the root node
#endif
    while (true) {
        LOOP_TICK();
        int a = int(cur & BVH_ADDR_MASK);
        uvec4 x0 = texelFetch(u_nodes, a);
        uvec4 x1 = texelFetch(u_nodes, a + 1);
        uvec4 x2 = texelFetch(u_nodes, a + 2);
        uvec4 x3 = texelFetch(u_nodes, a + 3);
        BVH_COUNT(1, 4);
        bool next_valid;
        uint next;
        if (cur >= BVH_LEAF_ONE) {
            // Triangle record: (v0, index), (v1, 0), (v2, 0); x3 belongs to the next record.
            BVH_COUNT_TRIS(1);
            float t; vec2 bary;
            if (intersect_tri_verts(r, p, uintBitsToFloat(x0.xyz), uintBitsToFloat(x1.xyz),
                                    uintBitsToFloat(x2.xyz), h.t, t, bary)) {
                h.t = t; h.tri = int(x0.w); h.bary = bary; found = true;
                if (any_hit) break;
            }
            next_valid = cur >= 2u * BVH_LEAF_ONE;       // more triangles in this leaf
            next = cur - BVH_LEAF_ONE + 3u;
        } else {
            // Node record: both children's boxes and references.
            BVH_COUNT_NODE();
            float tl, tr;
            bool hl = box_hit(uintBitsToFloat(x0.xyz), uintBitsToFloat(x1.xyz), r.o, inv, h.t, tl);
            bool hr = box_hit(uintBitsToFloat(x2.xyz), uintBitsToFloat(x3.xyz), r.o, inv, h.t, tr);
            bool left_first = tl <= tr;
            uint near = left_first ? x0.w : x2.w;
            uint far = left_first ? x2.w : x0.w;
            if (hl && hr) stack[sp++] = far;
            next_valid = hl || hr;
            next = (hl && hr) ? near : (hl ? x0.w : x2.w);
        }
        if (next_valid) {
            cur = next;
        } else {
            if (sp == 0) break;
            cur = stack[--sp];
        }
    }
    return found;
}

#elif MCPT_TRI_CONST == 0
// No BVH, the triangle count a uniform: BVH_MAX_LEAF triangles per iteration (fewer loop
// iterations, see common.glsl).
bool trace_brute(Ray r, RayPre p, inout Hit h, bool any_hit) {
    bool found = false;
    for (int i = 0; i < u_tri_count; i += BVH_MAX_LEAF) {
        LOOP_TICK();
        BVH_COUNT(1, 3 * BVH_MAX_LEAF);
        BVH_COUNT_TRIS(BVH_MAX_LEAF);
        if (leaf_hit(r, p, i, min(BVH_MAX_LEAF, u_tri_count - i), any_hit, h)) {
            found = true;
            if (any_hit) return true;
        }
    }
    return found;
}
#endif

// The closest hit nearer than h.t (any_hit: any hit, the first found), by the structure the
// scene was compiled with.
bool trace_triangles(Ray r, inout Hit h, bool any_hit) {
    RayPre p = ray_pre(r.d);
#if MCPT_BVH && MCPT_BVH_DENSE
    return trace_dense(r, p, h, any_hit);
#elif MCPT_BVH
    return trace_bvh(r, p, h, any_hit);
#elif MCPT_TRI_CONST > 0
    return trace_const(r, p, any_hit, h);
#else
    return trace_brute(r, p, h, any_hit);
#endif
}

// ... among the triangles, then the analytic spheres (sphere.glsl), which need h.t as found.
bool trace(Ray r, inout Hit h, bool any_hit) {
    bool found = trace_triangles(r, h, any_hit);
#if MCPT_SPHERES
    if (!(any_hit && found)) found = trace_spheres(r, any_hit, h) || found;
#endif
    return found;
}

#if MCPT_COUNTERS
void bvh_count_flush(bool shadow) {
    atomicAdd(c_rays, 1u); atomicAdd(c_iterations, g_iter); atomicAdd(c_fetches, g_fetch);
    atomicAdd(c_nodes, g_node); atomicAdd(c_tris, g_tri); atomicAdd(c_shadow, shadow ? 1u : 0u);
    // Batch iterations in 1/256ths (a sum of 1/k, k <= 8 on llvmpipe: exact in float).
    atomicAdd(c_batch, uint(g_batch * 256.0 + 0.5)); atomicMax(c_lanes, uint(BATCH_LANES));
    g_iter = 0u; g_fetch = 0u; g_node = 0u; g_tri = 0u; g_batch = 0.0;
}
#define BVH_FLUSH(shadow) bvh_count_flush(shadow)
#else
#define BVH_FLUSH(shadow)
#endif

#if MCPT_OPACITY
#include "opacity.glsl"
#endif

bool trace_closest(Ray r, out Hit h) {
    h.t = INF; h.tri = -1; h.bary = vec2(0.0);
#if MCPT_OPACITY
    bool found = trace_through(r, INF, false, h);  // opacity.glsl: cut-outs let the ray through
#else
    bool found = trace(r, h, false);
#endif
    BVH_FLUSH(false);
    return found;
}

// True when nothing blocks the segment from r.o to r.o + tmax * r.d.
bool visible(Ray r, float tmax) {
    Hit h; h.t = tmax; h.tri = -1; h.bary = vec2(0.0);
#if MCPT_OPACITY
    bool blocked = trace_through(r, tmax, true, h);
#else
    bool blocked = trace(r, h, true);
#endif
    BVH_FLUSH(true);
    return !blocked;
}
