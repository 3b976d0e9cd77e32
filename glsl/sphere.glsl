// Analytic spheres (host side: mcpt/shapes/sphere.py pack_spheres, which documents the layout):
// MCPT_SPHERES spheres, 5 RGBA32UI texels each, tested by every ray after the triangles. A sphere
// hit is Hit.tri = SPHERE_BASE + k and carries its outward unit normal, octahedral-encoded in
// floats (Cigolle et al. 2014), in Hit.bary: the uv and frame follow from it.
//
// The test runs in double precision, as Mitsuba 3's sphere does on the CPU (src/shapes/
// sphere.cpp, Double = Float64 off CUDA): in float32 |f|^2 - r^2 loses all its digits when the
// radius is large against the distance to the surface (a planet of radius 6.4e6 seen from two
// units above it: ulp(r^2) ~ 4e6 against 2 r h ~ 2.6e7), and the centre itself, relative to the
// camera, is off by up to half a unit (tests/test_sphere.py furnaces). The centre is stored as
// doubles; the hit point is projected back onto the sphere in double (sphere_point).
// Included by geometry.glsl only when the scene has one (MCPT_SPHERES > 0).
layout(binding = 15) uniform usamplerBuffer u_spheres;

const int SPHERE_BASE = 0x40000000;  // above every triangle index (2^28 texels at most)
const int SPHERE_TEXELS = 5;         // mcpt/shapes/sphere.py TEXELS

bool hit_is_sphere(int tri) { return tri >= SPHERE_BASE; }
uvec4 sphere_texel(int tri, int k) { return texelFetch(u_spheres, SPHERE_TEXELS * (tri - SPHERE_BASE) + k); }
int sphere_material(int tri) { return int(sphere_texel(tri, 1).w); }

// Centre (double) and radius (float, widened) of sphere k.
dvec4 sphere_shape(int k) {
    uvec4 a = texelFetch(u_spheres, SPHERE_TEXELS * k), b = texelFetch(u_spheres, SPHERE_TEXELS * k + 1);
    return dvec4(packDouble2x32(a.xy), packDouble2x32(a.zw), packDouble2x32(b.xy), double(uintBitsToFloat(b.z)));
}

vec2 sphere_oct_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if (n.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    return p;
}

// The outward unit normal of a sphere hit (common.glsl oct_unfold).
vec3 sphere_normal(Hit h) { return normalize(oct_unfold(h.bary)); }

// The geometric normal whose side is the front: outward, inward where the normals are flipped.
vec3 sphere_front_normal(Hit h) { return sphere_normal(h) * uintBitsToFloat(sphere_texel(h.tri, 2).w); }

// The hit point of ray r: o + t d projected back onto the sphere, in double, so that it lies on
// the surface to the rounding of its own coordinates whatever the rounding of t (a ray from far
// away would otherwise land inside by more than offset_ray's margin and hit the sphere again).
vec3 sphere_point(Hit h, Ray r) {
    dvec4 s = sphere_shape(h.tri - SPHERE_BASE);
    dvec3 v = dvec3(r.o) + double(h.t) * dvec3(r.d) - s.xyz;
    return vec3(s.xyz + s.w * v / sqrt(dot(v, v)));
}

// Mitsuba 3's sphere uv (src/shapes/sphere.cpp): (phi / 2 pi, theta / pi) of the normal in the
// sphere's own frame, phi from +x towards +y, theta from +z; mcpt's v points up (1 - v).
vec2 sphere_uv(Hit h) {
    vec3 n = sphere_normal(h);
    vec3 l = vec3(dot(uintBitsToFloat(sphere_texel(h.tri, 2).xyz), n),
                  dot(uintBitsToFloat(sphere_texel(h.tri, 3).xyz), n),
                  dot(uintBitsToFloat(sphere_texel(h.tri, 4).xyz), n));
    float u = atan(l.y, l.x) * (0.5 / PI);
    return vec2(u < 0.0 ? u + 1.0 : u, 1.0 - acos(clamp(l.z, -1.0, 1.0)) * (1.0 / PI));
}

// Ray / sphere with the discriminant of Haines et al., "Precision Improvements for Ray/Sphere
// Intersection" (Ray Tracing Gems ch. 7, 2019): r^2 - |f - (f.d / d.d) d|^2 instead of b^2 - ac,
// and the near root as c / q, in double (above). A ray leaving a sphere's surface (origin
// offset by offset_ray, common.glsl) finds that surface again at |t| of the order of the double
// rounding of |f|^2 - r^2 (~1e-16 r / cos); roots below 1e-9 r are taken for it and skipped (the
// ray's other root is then the true one: the far side for a ray going in).
bool sphere_hit(Ray r, dvec4 s, float tmax, out float t) {
    dvec3 d = dvec3(r.d);
    dvec3 f = dvec3(r.o) - s.xyz;
    double a = dot(d, d);
    double b = -dot(f, d);
    dvec3 l = f + (b / a) * d;
    double dl = sqrt(dot(l, l));
    double disc = a * (s.w - dl) * (s.w + dl);
    double c = dot(f, f) - s.w * s.w;
    double q = b + (b >= 0.0 ? 1.0 : -1.0) * sqrt(max(disc, 0.0));
    double t0 = c / q, t1 = q / a;
    double tn = min(t0, t1), tf = max(t0, t1);
    double eps = 1e-9 * s.w;
    double tt = tn > eps ? tn : tf;
    t = float(tt);
    return disc >= 0.0 && tt > eps && t < tmax;  // q = 0 (a = 0 or a tangent through f): no hit
}

// The closest sphere nearer than h.t (any_hit: any one). The loop has a constant bound: it is
// written out, costing no iterations of llvmpipe's loop budget (common.glsl).
bool trace_spheres(Ray r, bool any_hit, inout Hit h) {
    int hit = -1;
    for (int k = 0; k < MCPT_SPHERES; ++k) {
        float t;
        if (sphere_hit(r, sphere_shape(k), h.t, t)) {
            h.t = t;
            hit = k;
            if (any_hit) break;
        }
    }
    if (hit < 0) return false;
    h.tri = SPHERE_BASE + hit;
    dvec4 s = sphere_shape(hit);
    h.bary = sphere_oct_encode(vec3(normalize(dvec3(r.o) + double(h.t) * dvec3(r.d) - s.xyz)));
    return true;
}
