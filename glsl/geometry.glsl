// Triangles (host side: mcpt/shapes/geometry.py pack_triangles). Three RGBA32UI texels per triangle:
//   (v0.xyz as float bits, material id), (v1.xyz, 0), (v2.xyz, 0)
// in BVH leaf order, positions relative to the camera (rebased on the CPU in float64).
layout(binding = 2) uniform usamplerBuffer u_tris;
uniform int u_tri_count;

vec3 tri_vertex(int tri, int k) { return uintBitsToFloat(texelFetch(u_tris, 3 * tri + k).xyz); }

struct Hit {
    float t;      // ray parameter of the closest hit so far (INF: none)
    int tri;      // triangle index (-1: none; SPHERE_BASE + k: analytic sphere k, sphere.glsl)
    vec2 bary;    // barycentrics of v1 and v2 (a sphere: its normal, octahedral)
};

#ifndef MCPT_SPHERES
#define MCPT_SPHERES 0
#endif
#if MCPT_SPHERES
#include "sphere.glsl"
#define HIT_IS_SPHERE(tri) hit_is_sphere(tri)
#else
#define HIT_IS_SPHERE(tri) false
#endif

// The material of triangle (or sphere) tri.
int tri_material(int tri) {
#if MCPT_SPHERES
    if (hit_is_sphere(tri)) return sphere_material(tri);
#endif
    return int(texelFetch(u_tris, 3 * tri).w);
}

// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013, JCGT 2(1)): the
// permutation (kx, ky, kz) that makes the ray's largest direction component z, and the shear
// that maps the ray onto +z. Both are linear, so they fold into one matrix M:
//   M v = (v[kx] - Sx v[kz], v[ky] - Sy v[kz], Sz v[kz]).
// A matrix product vectorises well on llvmpipe, where indexing a vec3 with a variable does not,
// and it is still a function of the vertex alone, so a vertex shared by two triangles maps to
// the same point in both: that is all watertightness needs.
struct RayPre { mat3 M; };

RayPre ray_pre(vec3 d) {
    vec3 ad = abs(d);
    int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0) { int t = kx; kx = ky; ky = t; }  // keep the winding
    float sz = 1.0 / d[kz];
    float sx = d[kx] * sz, sy = d[ky] * sz;
    vec3 ex = vec3(0.0), ey = vec3(0.0), ez = vec3(0.0);
    ex[kx] = 1.0; ey[ky] = 1.0; ez[kz] = 1.0;
    RayPre p;
    // GLSL matrices are column-major: M = transpose(rows).
    p.M = transpose(mat3(ex - sx * ez, ey - sy * ez, sz * ez));
    return p;
}

// Watertight ray/triangle test: a ray through a shared edge or vertex hits at least one of the
// triangles sharing it. `precise` stops fast-math from contracting the 2x2 determinants into
// FMAs, which would break the exact antisymmetry of an edge shared by two triangles.
//
// Split in two so that a vertex shared by several triangles can be sheared once per ray
// (glsl/bvh.glsl, small scenes): tri_shear of a vertex, then the test on three sheared vertices.
vec3 tri_shear(Ray r, RayPre p, vec3 v) {
    precise vec3 a = p.M * (v - r.o);
    return a;
}

// The edge function of sheared vertices P, Q: e(Q, P) == -e(P, Q) exactly (the same two
// products, subtracted the other way round), so glsl/bvh.glsl computes an edge shared by two
// triangles once per ray (issue #23). `precise`: no FMA, or the antisymmetry is lost.
float edge_fn(vec3 P, vec3 Q) {
    precise float e = P.x * Q.y - P.y * Q.x;
    return e;
}

// The test on the edge functions U = e(C, B), V = e(A, C), W = e(B, A) and the sheared depths.
bool intersect_edges(float U, float V, float W, float Az, float Bz, float Cz, float tmax,
                     out float t, out vec2 bary) {
    if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return false;
    float det = U + V + W;
    if (det == 0.0) return false;
    float T = U * Az + V * Bz + W * Cz;
    float inv = 1.0 / det;
    t = T * inv;
    if (!(t > 0.0 && t < tmax)) return false;  // also rejects NaN
    bary = vec2(V, W) * inv;
    return true;
}

// T s of the edge functions and sheared depths (T = U Az + V Bz + W Cz, as intersect_edges), with
// s the sign of det = U + V + W and ds = det s = |det| (sign flips: exact).
float signed_depth(float U, float V, float W, float Az, float Bz, float Cz, out float s, out float ds) {
    float det = U + V + W;
    s = det < 0.0 ? -1.0 : 1.0;
    ds = det * s;
    return (U * Az + V * Bz + W * Cz) * s;
}

// intersect_edges without its division, for the written-out small scenes (glsl/bvh.glsl
// trace_const; issue #23: llvmpipe runs every test's code, a division included, for every ray).
// t = T / det lies in (0, tmax) iff, with det's sign s folded into both (exact), 0 < T s and
// T s < tmax |det|; |det| = 0 fails the second. NaN fails both.
// ``outside``: intersect_edges' first test, (U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0),
// from sign tests made once per edge (mcpt/gpu/limits.py vertex_tables; an edge serves two
// triangles: 1.04x paths per CPU-second on the Cornell box).
bool edges_block(bool outside, float U, float V, float W, float Az, float Bz, float Cz, float tmax) {
    float s, ds;
    float Ts = signed_depth(U, V, W, Az, Bz, Cz, s, ds);
    return !outside && Ts > 0.0 && Ts < tmax * ds;
}

// The closest of the tests so far as (bT, bD, bB, bI): t = bT / bD, bary = bB / bD, bD > 0,
// triangle bI (-1: none; bT = tmax, bD = 1 at the start). t < t_best iff T s bD < bT |det|.
void edges_closer(bool outside, float U, float V, float W, float Az, float Bz, float Cz, int idx,
                  inout float bT, inout float bD, inout vec2 bB, inout int bI) {
    float s, ds;
    float Ts = signed_depth(U, V, W, Az, Bz, Cz, s, ds);
    if (!outside && Ts > 0.0 && Ts * bD < bT * ds) {
        bT = Ts; bD = ds; bB = vec2(V, W) * s; bI = idx;
    }
}

bool intersect_sheared(vec3 A, vec3 B, vec3 C, float tmax, out float t, out vec2 bary) {
    return intersect_edges(edge_fn(C, B), edge_fn(A, C), edge_fn(B, A), A.z, B.z, C.z, tmax, t, bary);
}

bool intersect_tri_verts(Ray r, RayPre p, vec3 v0, vec3 v1, vec3 v2, float tmax,
                         out float t, out vec2 bary) {
    return intersect_sheared(tri_shear(r, p, v0), tri_shear(r, p, v1), tri_shear(r, p, v2),
                             tmax, t, bary);
}

bool intersect_tri(Ray r, RayPre p, int tri, float tmax, out float t, out vec2 bary) {
    return intersect_tri_verts(r, p, tri_vertex(tri, 0), tri_vertex(tri, 1), tri_vertex(tri, 2),
                               tmax, t, bary);
}

vec3 tri_point(int tri, vec2 bary) {
    vec3 v0 = tri_vertex(tri, 0);
    return v0 + bary.x * (tri_vertex(tri, 1) - v0) + bary.y * (tri_vertex(tri, 2) - v0);
}

// Unnormalised geometric normal; its side is the front (counter-clockwise winding, scene.json).
vec3 tri_normal_raw(int tri) {
    vec3 v0 = tri_vertex(tri, 0);
    return cross(tri_vertex(tri, 1) - v0, tri_vertex(tri, 2) - v0);
}

// The unnormalised geometric normal at hit h, whose side is the front.
vec3 hit_normal_raw(Hit h) {
#if MCPT_SPHERES
    if (hit_is_sphere(h.tri)) return sphere_front_normal(h);
#endif
    return tri_normal_raw(h.tri);
}

// The point of hit h on ray r.
vec3 hit_point(Hit h, Ray r) {
#if MCPT_SPHERES
    if (hit_is_sphere(h.tri)) return sphere_point(h, r);
#endif
    return tri_point(h.tri, h.bary);
}
