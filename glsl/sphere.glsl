// Analytic spheres (host side: mcpt/shapes/sphere.py pack_spheres, which documents the layout):
// MCPT_SPHERES spheres, 4 RGBA32UI texels each, tested by every ray after the triangles. A sphere
// hit is Hit.tri = SPHERE_BASE + k and carries its outward unit normal, octahedral-encoded in
// floats (Cigolle et al. 2014), in Hit.bary: the point, uv and frame follow from it exactly.
// Included by geometry.glsl only when the scene has one (MCPT_SPHERES > 0).
layout(binding = 15) uniform usamplerBuffer u_spheres;

const int SPHERE_BASE = 0x40000000;  // above every triangle index (2^28 texels at most)

bool hit_is_sphere(int tri) { return tri >= SPHERE_BASE; }
vec4 sphere_texel(int tri, int k) { return uintBitsToFloat(texelFetch(u_spheres, 4 * (tri - SPHERE_BASE) + k)); }
int sphere_material(int tri) { return int(texelFetch(u_spheres, 4 * (tri - SPHERE_BASE) + 1).w); }

vec2 sphere_oct_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if (n.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    return p;
}

vec3 sphere_oct_decode(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    float t = max(-n.z, 0.0);
    n.x += n.x >= 0.0 ? -t : t;
    n.y += n.y >= 0.0 ? -t : t;
    return normalize(n);
}

// The outward unit normal of a sphere hit.
vec3 sphere_normal(Hit h) { return sphere_oct_decode(h.bary); }

// The geometric normal whose side is the front: outward, inward where the normals are flipped.
vec3 sphere_front_normal(Hit h) { return sphere_normal(h) * sphere_texel(h.tri, 2).w; }

// The hit point, on the sphere to float precision (centre + radius x normal): a better origin
// for the next ray than o + t d, whose error grows with t.
vec3 sphere_point(Hit h) {
    vec4 c = sphere_texel(h.tri, 0);
    return c.xyz + c.w * sphere_normal(h);
}

// Mitsuba 3's sphere uv (src/shapes/sphere.cpp): (phi / 2 pi, theta / pi) of the normal in the
// sphere's own frame, phi from +x towards +y, theta from +z; mcpt's v points up (1 - v).
vec2 sphere_uv(Hit h) {
    vec3 n = sphere_normal(h);
    vec3 l = vec3(dot(sphere_texel(h.tri, 1).xyz, n), dot(sphere_texel(h.tri, 2).xyz, n),
                  dot(sphere_texel(h.tri, 3).xyz, n));
    float u = atan(l.y, l.x) * (0.5 / PI);
    return vec2(u < 0.0 ? u + 1.0 : u, 1.0 - acos(clamp(l.z, -1.0, 1.0)) * (1.0 / PI));
}

// Ray / sphere with the discriminant of Haines et al., "Precision Improvements for Ray/Sphere
// Intersection" (Ray Tracing Gems ch. 7, 2019): r^2 - |f - (f.d / d.d) d|^2 instead of b^2 - ac,
// which cancels catastrophically for small or distant spheres, and the near root as c / q.
// A ray leaving a sphere's surface (origin offset by offset_ray, common.glsl) finds that surface
// again at |t| of the order of the rounding of |f|^2 - r^2; roots below 1e-6 r are taken for it
// and skipped (the ray's other root is then the true one: the far side for a ray going in).
bool sphere_hit(Ray r, vec4 s, float tmax, out float t) {
    vec3 f = r.o - s.xyz;
    float a = dot(r.d, r.d);
    float b = -dot(f, r.d);
    vec3 l = f + (b / a) * r.d;
    float dl = length(l);
    float disc = a * (s.w - dl) * (s.w + dl);
    float c = dot(f, f) - s.w * s.w;
    float q = b + (b >= 0.0 ? 1.0 : -1.0) * sqrt(max(disc, 0.0));
    float t0 = c / q, t1 = q / a;
    float tn = min(t0, t1), tf = max(t0, t1);
    float eps = 1e-6 * s.w;
    t = tn > eps ? tn : tf;
    return disc >= 0.0 && t > eps && t < tmax;  // also rejects NaN (q = 0: a ray through the centre's tangent)
}

// The closest sphere nearer than h.t (any_hit: any one). The loop has a constant bound: it is
// written out, costing no iterations of llvmpipe's loop budget (common.glsl).
bool trace_spheres(Ray r, bool any_hit, inout Hit h) {
    int hit = -1;
    for (int k = 0; k < MCPT_SPHERES; ++k) {
        vec4 s = uintBitsToFloat(texelFetch(u_spheres, 4 * k));
        float t;
        if (sphere_hit(r, s, h.t, t)) {
            h.t = t;
            hit = k;
            if (any_hit) break;
        }
    }
    if (hit < 0) return false;
    h.tri = SPHERE_BASE + hit;
    vec4 s = uintBitsToFloat(texelFetch(u_spheres, 4 * hit));
    h.bary = sphere_oct_encode(normalize(r.o + h.t * r.d - s.xyz));
    return true;
}
