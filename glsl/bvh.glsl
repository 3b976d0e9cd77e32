// Closest-hit and any-hit traversal (host side: mcpt/shapes/bvh.py BVH.gpu_nodes defines the layout).
// Interior node = 4 RGBA32UI texels, both children's boxes:
//   (left.bmin, left.a), (left.bmax, left.b), (right.bmin, right.a), (right.bmax, right.b)
// child b == 0: interior node a; else leaf with first triangle a, count b & 0x7fffffff.
#include "geometry.glsl"

layout(binding = 1) uniform usamplerBuffer u_nodes;
#define BVH_STACK 64   // >= tree depth + 2, asserted by the builder (mcpt/shapes/bvh.py MAX_STACK)
#define BVH_MAX_LEAF 4 // triangles per leaf at most (mcpt/shapes/bvh.py GPU_MAX_LEAF, asserted there)

// Slab test. Zero direction components are replaced by a tiny value upstream (safe_inv) so no
// 0 * inf = NaN appears; the far distance is widened by 2 gamma(3) (Ize 2013, "Robust BVH Ray
// Traversal") so rounding never misses a box the ray really enters.
bool box_hit(vec3 bmin, vec3 bmax, vec3 o, vec3 inv, float tmax, out float tnear) {
    vec3 t0 = (bmin - o) * inv;
    vec3 t1 = (bmax - o) * inv;
    vec3 tsm = min(t0, t1);
    vec3 tbg = max(t0, t1);
    // A ray parallel to a slab (|inv| huge: safe_inv replaced a zero component) whose origin lies
    // exactly on one of the slab's planes got 0 * inv = 0 there, i.e. left the box at t = 0, so a
    // ray running inside a box face (flat boxes of axis-aligned walls) missed the box (issue #6,
    // case watertight-flat-grid-axis-rays). Such a ray stays in the slab for every t when its
    // origin is inside it, bounds included: push the slab's far distance out of reach.
    tbg += step(1e29, abs(inv)) * step(bmin, o) * step(o, bmax) * 3e38;
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

// any_hit = true: return on the first hit with t < h.t (shadow rays).
bool trace(Ray r, inout Hit h, bool any_hit) {
    RayPre p = ray_pre(r.d);
    bool found = false;
#if MCPT_BVH
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
        float tl, tr;
        bool hl = box_hit(uintBitsToFloat(l0.xyz), uintBitsToFloat(l1.xyz), r.o, inv, h.t, tl);
        bool hr = box_hit(uintBitsToFloat(r0.xyz), uintBitsToFloat(r1.xyz), r.o, inv, h.t, tr);
        // Leaf children are intersected right here; only interior children are descended into.
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
#else
    // BVH_MAX_LEAF triangles per iteration: fewer loop iterations (see common.glsl).
    for (int i = 0; i < u_tri_count; i += BVH_MAX_LEAF) {
        LOOP_TICK();
        if (leaf_hit(r, p, i, min(BVH_MAX_LEAF, u_tri_count - i), any_hit, h)) {
            found = true;
            if (any_hit) return true;
        }
    }
#endif
    return found;
}

bool trace_closest(Ray r, out Hit h) {
    h.t = INF; h.tri = -1; h.bary = vec2(0.0);
    return trace(r, h, false);
}

// True when nothing blocks the segment from r.o to r.o + tmax * r.d.
bool visible(Ray r, float tmax) {
    Hit h; h.t = tmax; h.tri = -1; h.bary = vec2(0.0);
    return !trace(r, h, true);
}
