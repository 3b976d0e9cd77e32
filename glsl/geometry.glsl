// Triangles (host side: mcpt/geometry.py). Three RGBA32UI texels per triangle:
//   (v0.xyz as float bits, material id), (v1.xyz, 0), (v2.xyz, 0)
// in BVH leaf order, positions relative to the camera (rebased on the CPU in float64).
layout(binding = 2) uniform usamplerBuffer u_tris;
uniform int u_tri_count;

vec3 tri_vertex(int tri, int k) { return uintBitsToFloat(texelFetch(u_tris, 3 * tri + k).xyz); }
int tri_material(int tri) { return int(texelFetch(u_tris, 3 * tri).w); }

struct Hit {
    float t;      // ray parameter of the closest hit so far (INF: none)
    int tri;      // triangle index (-1: none)
    vec2 bary;    // barycentrics of v1 and v2
};

// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013, JCGT 2(1)).
struct RayPre { int kx; int ky; int kz; vec3 S; };

RayPre ray_pre(vec3 d) {
    vec3 ad = abs(d);
    RayPre p;
    p.kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    p.kx = p.kz == 2 ? 0 : p.kz + 1;
    p.ky = p.kx == 2 ? 0 : p.kx + 1;
    if (d[p.kz] < 0.0) { int t = p.kx; p.kx = p.ky; p.ky = t; }  // keep the winding
    p.S = vec3(d[p.kx] / d[p.kz], d[p.ky] / d[p.kz], 1.0 / d[p.kz]);
    return p;
}

// Watertight ray/triangle test: a ray through a shared edge or vertex hits at least one of the
// triangles sharing it. `precise` stops fast-math from contracting the 2x2 determinants into
// FMAs, which would break the exact antisymmetry of an edge shared by two triangles.
bool intersect_tri(Ray r, RayPre p, int tri, float tmax, out float t, out vec2 bary) {
    vec3 A = tri_vertex(tri, 0) - r.o;
    vec3 B = tri_vertex(tri, 1) - r.o;
    vec3 C = tri_vertex(tri, 2) - r.o;
    precise float Ax = A[p.kx] - p.S.x * A[p.kz];
    precise float Ay = A[p.ky] - p.S.y * A[p.kz];
    precise float Bx = B[p.kx] - p.S.x * B[p.kz];
    precise float By = B[p.ky] - p.S.y * B[p.kz];
    precise float Cx = C[p.kx] - p.S.x * C[p.kz];
    precise float Cy = C[p.ky] - p.S.y * C[p.kz];
    precise float U = Cx * By - Cy * Bx;
    precise float V = Ax * Cy - Ay * Cx;
    precise float W = Bx * Ay - By * Ax;
    if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return false;
    float det = U + V + W;
    if (det == 0.0) return false;
    float T = U * (p.S.z * A[p.kz]) + V * (p.S.z * B[p.kz]) + W * (p.S.z * C[p.kz]);
    float inv = 1.0 / det;
    t = T * inv;
    if (!(t > 0.0 && t < tmax)) return false;  // also rejects NaN
    bary = vec2(V, W) * inv;
    return true;
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
