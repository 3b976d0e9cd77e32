// Closest-hit and any-hit traversal (host side: mcpt/bvh.py, which defines the node layout).
// Node = 2 RGBA32UI texels: (bmin.xyz, a), (bmax.xyz, b). Leaf: b has the top bit set,
// a = first triangle, b & 0x7fffffff = count. Interior: left child = node + 1, a = right child,
// b = split axis (children visited near-first along it).
#include "geometry.glsl"

layout(binding = 1) uniform usamplerBuffer u_nodes;
#define BVH_STACK 64   // >= tree depth + 2, asserted by the builder (mcpt/bvh.py MAX_STACK)

// Slab test. Zero direction components are replaced by a tiny value upstream (safe_inv) so no
// 0 * inf = NaN appears; the far distance is widened by 2 gamma(3) (Ize 2013, "Robust BVH Ray
// Traversal") so rounding never misses a box the ray really enters.
bool box_hit(vec3 bmin, vec3 bmax, vec3 o, vec3 inv, float tmax) {
    vec3 t0 = (bmin - o) * inv;
    vec3 t1 = (bmax - o) * inv;
    vec3 tsm = min(t0, t1);
    vec3 tbg = max(t0, t1);
    float tn = max(max(tsm.x, tsm.y), max(tsm.z, 0.0));
    float tf = min(min(tbg.x, tbg.y), min(tbg.z, tmax)) * 1.0000004;
    return tn <= tf;
}

vec3 safe_inv(vec3 d) {
    const float TINY = 1e-30;
    return 1.0 / vec3(abs(d.x) < TINY ? (d.x < 0.0 ? -TINY : TINY) : d.x,
                      abs(d.y) < TINY ? (d.y < 0.0 ? -TINY : TINY) : d.y,
                      abs(d.z) < TINY ? (d.z < 0.0 ? -TINY : TINY) : d.z);
}

// any_hit = true: return on the first hit with t < h.t (shadow rays).
bool trace(Ray r, inout Hit h, bool any_hit) {
    RayPre p = ray_pre(r.d);
    bool found = false;
    float t; vec2 bary;
#if MCPT_BVH
    vec3 inv = safe_inv(r.d);
    int stack[BVH_STACK];
    int sp = 0;
    int node = 0;
    while (true) {
        uvec4 a = texelFetch(u_nodes, 2 * node);
        uvec4 b = texelFetch(u_nodes, 2 * node + 1);
        if (box_hit(uintBitsToFloat(a.xyz), uintBitsToFloat(b.xyz), r.o, inv, h.t)) {
            if ((b.w & 0x80000000u) != 0u) {
                int first = int(a.w);
                int end = first + int(b.w & 0x7fffffffu);
                for (int i = first; i < end; ++i) {
                    if (intersect_tri(r, p, i, h.t, t, bary)) {
                        h.t = t; h.tri = i; h.bary = bary; found = true;
                        if (any_hit) return true;
                    }
                }
            } else {
                int left = node + 1;
                int right = int(a.w);
                bool neg = r.d[int(b.w)] < 0.0;
                stack[sp++] = neg ? left : right;
                node = neg ? right : left;
                continue;
            }
        }
        if (sp == 0) break;
        node = stack[--sp];
    }
#else
    for (int i = 0; i < u_tri_count; ++i) {
        if (intersect_tri(r, p, i, h.t, t, bary)) {
            h.t = t; h.tri = i; h.bary = bary; found = true;
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
