// Lights and the two ways a path finds them (host side: mcpt/shading/lights.py): a BSDF-sampled
// ray that hits an emitter (emitted_radiance) and next-event estimation (next_event), combined by
// multiple importance sampling (Veach 1997, ch. 9; which vertices use which: the "Sampling" note
// in glsl/pathtrace.frag).
//
// One light type today: emissive triangles (area lights), the u_lights table below. A new light
// type is one new file pair (glsl/light_<type>.glsl beside mcpt/shading/light_<type>.py: its
// emission, its sample and its pdf) plus one line in each dispatch marked below, and, for a light
// no ray can hit (a point) or one found by escaping rays (an environment), one line where
// path_step's ray misses or hits.
#include "path_state.glsl"
#include "sampler.glsl"
#include "normal_map.glsl"
#include "bvh.glsl"
#include "materials.glsl"

// Power heuristic with beta = 2 (Veach 1997, sec. 9.2.4).
float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

// MIS weight of emission that the ray of P found at hit h (cos_o = dot(n, ray.d) < 0). Weight 1
// after the camera or a delta bounce, which light sampling cannot imitate; 0 where light sampling
// alone counts (NEE without MIS).
float emitter_weight(Path P, Material m, Hit h, float cos_o) {
    float w = 1.0;
#if MCPT_NEE
#if MCPT_DELTA
    bool light_sampled = !P.delta_prev;  // the previous vertex also took a light sample
#else
    bool light_sampled = P.k > 1;
#endif
    if (light_sampled) {
#if MCPT_MIS
        // Density with which NEE would have produced this point, as a solid angle.
        float pdf_light = m.light_pdf_area * h.t * h.t / -cos_o;
        w = power_heuristic(P.pdf_bsdf_prev, pdf_light);
#else
        w = 0.0;  // NEE-only: light is found by light sampling alone
#endif
    }
#endif
    return w;
}

// Emitted radiance at hit h, seen from the front, added to P.L with its MIS weight.
// Dispatch (emitters a ray can hit): area lights are emissive materials; a new type, one line here.
void emitted_radiance(inout Path P, Material m, Hit h, float cos_o) {
    if (cos_o < 0.0 && max(m.emission.r, max(m.emission.g, m.emission.b)) > 0.0) {
        P.L += P.beta * m.emission * emitter_weight(P, m, h, cos_o);
    }
}

#if MCPT_NEE
// Emissive triangles for next-event estimation.
// One RGBA32UI texel per emissive triangle: (triangle, cdf upper bound bits, pmf bits, 0), picked
// with probability proportional to emitted power x area. A point is then sampled uniformly on
// the triangle, so the area density is pmf / area = luminance(Le) / total power.
layout(binding = 3) uniform usamplerBuffer u_lights;
uniform int u_light_count;

int light_pick(float u, out float pmf) {
#if MCPT_SINGLE_LIGHT
    uvec4 e = texelFetch(u_lights, 0);
#else
    // First entry whose cdf upper bound exceeds u (binary search over inclusive prefix sums).
    int lo = 0, hi = u_light_count - 1;
    while (lo < hi) {
        LOOP_TICK();
        int mid = (lo + hi) >> 1;
        if (uintBitsToFloat(texelFetch(u_lights, mid).y) > u) hi = mid; else lo = mid + 1;
    }
    uvec4 e = texelFetch(u_lights, lo);
#endif
    pmf = uintBitsToFloat(e.z);
    return int(e.x);
}

// Uniform point on a triangle (square-root parametrisation, pbrt-v4 SampleUniformTriangle).
vec2 sample_triangle_bary(vec2 u) {
    float su = sqrt(u.x);
    return vec2(u.y * su, 1.0 - su);  // (b1, b2) for v1, v2
}

// A point y sampled on a light, seen from a ray origin xo.
struct LightSample {
    int tri;      // the emissive triangle
    float pmf;    // probability of having picked it
    vec3 y;       // the point on it
    vec3 n;       // its unit geometric normal (the emitting side)
    float area2;  // twice its area
    vec3 wi;      // unit direction xo -> y
    float d2;     // squared distance xo -> y
    float cos_l;  // cosine at y towards xo (> 0: y faces xo)
};

// Dispatch (light sampling): every light is an emissive triangle; a new type, one line here
// choosing its light_<type>_sample by the picked entry.
LightSample light_sample(vec3 xo, int dim) {
    LightSample ls;
    ls.tri = light_pick(rand_at(dim + DIM_LIGHT_PICK), ls.pmf);
    vec2 bb = sample_triangle_bary(rand2_at(dim + DIM_LIGHT_UV));
    ls.y = tri_point(ls.tri, bb);
    vec3 nl = tri_normal_raw(ls.tri);
    ls.area2 = length(nl);
    nl /= ls.area2;
    ls.n = nl;
    vec3 dv = ls.y - xo;
    ls.d2 = dot(dv, dv);
    float dist = sqrt(ls.d2);
    ls.wi = dv / dist;
    ls.cos_l = -dot(nl, ls.wi);
    return ls;
}

// Solid-angle density of the sample (for cos_l > 0): pmf / area, turned by d^2 / cos_l.
float light_pdf(LightSample ls) { return ls.pmf * (2.0 / ls.area2) * ls.d2 / ls.cos_l; }

vec3 light_emission(LightSample ls) { return material(tri_material(ls.tri)).emission; }

// Nothing between xo and the light point (both offset off their surfaces).
bool light_visible(LightSample ls, vec3 xo) {
    vec3 yo = offset_ray(ls.y, ls.n);
    vec3 seg = yo - xo;
    float seg_len = length(seg);
    return visible(Ray(xo, seg / seg_len), seg_len);
}

// Next-event estimation at a vertex with a non-delta lobe (bsdf_has_smooth): one light sample,
// its contribution added to P.L with the power heuristic's weight (weight 1 without MCPT_MIS).
// Shading frame as in path_step: ns for the BSDF, ng the geometric side, xo the offset origin.
void next_event(inout Path P, Material m, vec3 ns, vec3 ng, vec3 wo, vec3 xo, int dim) {
    LightSample ls = light_sample(xo, dim);
    float pdf_b;
    vec3 fc = bsdf_eval(m, ns, wo, ls.wi, pdf_b);
#if MCPT_SMOOTH_NORMALS || MCPT_NORMAL_MAPS
    if (dot(ng, ls.wi) <= 0.0) fc = vec3(0.0);  // below the real surface: no light leaks in
    fc *= normal_map_shadow(ls.wi);  // normal_map.glsl (1 without normal maps)
#endif
    if (ls.cos_l > 0.0 && max(fc.r, max(fc.g, fc.b)) > 0.0) {
        float pdf_light = light_pdf(ls);
        if (light_visible(ls, xo)) {
            float w = 1.0;
#if MCPT_MIS
            w = power_heuristic(pdf_light, pdf_b);
#endif
            P.L += P.beta * fc * light_emission(ls) * (w / pdf_light);
        }
    }
}
#endif
