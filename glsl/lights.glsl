// Lights and the two ways a path finds them (host side: mcpt/shading/lights.py): a BSDF-sampled
// ray that hits an emitter (emitted_radiance) or escapes to the environment (env_escaped, in
// glsl/environment.glsl), and next-event estimation (next_event), combined by multiple importance
// sampling (Veach 1997, ch. 9; which vertices use which: the "Sampling" note in
// glsl/pathtrace.frag).
//
// Light types (issue #20), each compiled only when the scene has one: emissive triangles (area
// lights, MCPT_LIGHT_AREA), point / spot / directional lights (glsl/light_punctual.glsl: delta
// lights, found by NEE alone, weight 1; a sun disk, glsl/light_sun.glsl, is not) and the environment
// (glsl/environment.glsl, MCPT_LIGHT_ENV).
// All are entries of ONE table u_lights, picked with probability proportional to power. A new light
// type is one new file pair plus one line in each dispatch marked below.
#include "path_state.glsl"
#include "sampler.glsl"
#include "normal_map.glsl"
#include "bvh.glsl"
#include "materials.glsl"
#if MCPT_EMISSION_TEXTURES
#include "emission_texture.glsl"
#endif
#if MCPT_MEDIUM
// issue #25: shadow rays cross the scene's medium (medium_tr)
#include "medium.glsl"
#endif

// Entry kinds (mcpt/shading/lights.py KIND_*, mcpt/shading/light_punctual.py KIND_OF).
#define LIGHT_AREA 0u
#define LIGHT_POINT 1u
#define LIGHT_SPOT 2u
#define LIGHT_DIRECTIONAL 3u
#define LIGHT_ENV 4u
#define LIGHT_SUN 5u

// Power heuristic with beta = 2 (Veach 1997, sec. 9.2.4).
float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

// MIS weight of emission that P's ray found, which light sampling would have produced with
// solid-angle density pdf_light. Weight 1 after the camera or a delta bounce, which light
// sampling cannot imitate; 0 where light sampling alone counts (NEE without MIS).
float emitter_mis(Path P, float pdf_light) {
    float w = 1.0;
#if MCPT_NEE
#if MCPT_DELTA
    bool light_sampled = !P.delta_prev;  // the previous vertex also took a light sample
#else
    bool light_sampled = P.k > 1;
#endif
    if (light_sampled) {
#if MCPT_MIS
        w = power_heuristic(P.pdf_bsdf_prev, pdf_light);
#else
        w = 0.0;  // NEE-only: light is found by light sampling alone
#endif
    }
#endif
    return w;
}

// Emitted radiance at hit h (cos_o = dot(n, ray.d) < 0: seen from the front), added to P.L with
// its MIS weight. Dispatch (emitters a ray can hit): area lights are emissive materials.
void emitted_radiance(inout Path P, Material m, Hit h, float cos_o) {
#if MCPT_EMISSION_TEXTURES
    // Textured: radiance at the hit's UV; NEE's area density is per triangle (emission_texture.glsl).
    vec3 le = emission_at(m, h.tri, h.bary);
    float pdf_area = emitter_pdf_area(h.tri);
#else
    vec3 le = m.emission;
    float pdf_area = m.light_pdf_area;
#endif
    if (cos_o < 0.0 && max(le.r, max(le.g, le.b)) > 0.0) {
        // Density with which NEE would have produced this point, as a solid angle.
        P.L += P.beta * le * emitter_mis(P, pdf_area * h.t * h.t / -cos_o);
    }
}

// A light sampled from a ray origin xo (next-event estimation).
struct LightSample {
    vec3 wi;      // unit direction xo -> the light
    float dist;   // distance to the light along wi, world units (INF: at infinity)
    vec3 L;       // what arrives along wi: radiance, or I / d^2 of a point light (area: light_radiance)
    float pdf;    // solid-angle density of wi (0: no contribution); delta lights: the pick probability
    bool delta;   // a delta light: weight 1, no MIS
    int tri;      // area light: the emissive triangle (else -1)
    vec3 y;       // area light: the point on it
    vec3 n;       // area light: its unit geometric normal (the emitting side)
#if MCPT_EMISSION_TEXTURES
    vec2 bary;    // area light: the point's barycentrics (its UV for the emission texture)
#endif
};

#if MCPT_NEE
// The light table (mcpt/shading/lights.py): one RGBA32UI texel per light, (payload, cdf upper
// bound bits, pmf bits, kind), then the punctual lights' data texels.
layout(binding = 3) uniform usamplerBuffer u_lights;
uniform int u_light_count;

// The entry picked by u, and its probability; u_rest: where u lies inside the entry's cdf bucket,
// rescaled to [0, 1) (uniform given the pick), so the pick and the point on the light share one
// 2D sample as in Mitsuba 3 (Scene::sample_emitter_direction's sample_reuse): a stratified 2D
// sample then stays stratified over all emitters together, not only within each one.
uvec4 light_pick(float u, out float pmf, out float u_rest) {
#if MCPT_SINGLE_LIGHT
    uvec4 e = texelFetch(u_lights, 0);
    u_rest = u;
#else
    // First entry whose cdf upper bound exceeds u (binary search over inclusive prefix sums).
    int lo = 0, hi = u_light_count - 1;
#if MCPT_LIGHT_STEPS > 0
    // A few lights (mcpt/shading/lights.py search_steps): the ceil(log2(count)) steps written out,
    // no loop: a loop costs llvmpipe its mask bookkeeping on every path step (issue #23: 1.05x
    // paths per CPU-second on the Cornell box, two emissive triangles). Same steps, same pick.
    for (int i = 0; i < MCPT_LIGHT_STEPS; ++i) {  // a constant count: unrolled
        int mid = (lo + hi) >> 1;
        if (lo < hi) {
            if (uintBitsToFloat(texelFetch(u_lights, mid).y) > u) hi = mid; else lo = mid + 1;
        }
    }
#else
    while (lo < hi) {
        LOOP_TICK();
        int mid = (lo + hi) >> 1;
        if (uintBitsToFloat(texelFetch(u_lights, mid).y) > u) hi = mid; else lo = mid + 1;
    }
#endif
    uvec4 e = texelFetch(u_lights, lo);
    float c0 = lo > 0 ? uintBitsToFloat(texelFetch(u_lights, lo - 1).y) : 0.0;
    float c1 = min(uintBitsToFloat(e.y), 1.0);  // the last bound is +inf (mcpt/shading/lights.py)
    u_rest = clamp((u - c0) / max(c1 - c0, 1e-30), 0.0, 0.99999994);
#endif
    pmf = uintBitsToFloat(e.z);
    return e;
}

// The pick alone (media's equiangular sampling, tests/glsl/probe_sample.frag).
uvec4 light_pick(float u, out float pmf) {
    float u_rest;
    return light_pick(u, pmf, u_rest);
}
#endif

// Dispatch: one #include per light file.
#if MCPT_NEE && MCPT_LIGHT_AREA
#include "light_area.glsl"
#endif
#if MCPT_LIGHT_SUN
#include "light_sun.glsl"
#endif
#if MCPT_NEE && (MCPT_LIGHT_POINT || MCPT_LIGHT_SPOT || MCPT_LIGHT_DIRECTIONAL || MCPT_LIGHT_SUN)
#include "light_punctual.glsl"
#endif
#if MCPT_LIGHT_ENV
#include "environment.glsl"
#endif

#if MCPT_LIGHT_ENV || MCPT_LIGHT_SUN
// Dispatch (lights that rays leaving the scene find): P's ray, direction d, hit nothing.
void light_escaped(inout Path P, vec3 d) {
#if MCPT_LIGHT_ENV
    env_escaped(P, d);
#endif
#if MCPT_LIGHT_SUN
    sun_escaped(P, d);
#endif
}
#endif

#if MCPT_NEE
// The sample is on an emissive triangle (constant true where area lights are the only kind).
bool light_is_area(LightSample ls) {
#if MCPT_LIGHT_POINT || MCPT_LIGHT_SPOT || MCPT_LIGHT_DIRECTIONAL || MCPT_LIGHT_SUN || MCPT_LIGHT_ENV
    return ls.tri >= 0;
#else
    return true;
#endif
}

// Dispatch (light sampling): pick an entry, then sample the light of its kind.
LightSample light_sample(vec3 xo, int dim) {
    // One 2D sample picks the light (u.x) and, rescaled, places the point (issue #23: with a
    // separate number for the pick, a quad light's two triangles each got a random subset of the
    // Owen-scrambled net; sharing it is relMSE x0.97-0.98 at equal spp on the Cornell box and
    // the 100k sphere, bench/sampler-quality.md).
    float pmf;
    vec2 u = rand2_at(dim + DIM_LIGHT_UV);
    uvec4 e = light_pick(u.x, pmf, u.x);
    LightSample ls;
    ls.tri = -1;
    ls.delta = false;
#if MCPT_LIGHT_POINT || MCPT_LIGHT_SPOT || MCPT_LIGHT_DIRECTIONAL || MCPT_LIGHT_SUN
    if (e.w != LIGHT_AREA && e.w != LIGHT_ENV) {
        punctual_sample(ls, e, pmf, xo, u);
        return ls;
    }
#endif
#if MCPT_LIGHT_ENV
    if (e.w == LIGHT_ENV) { env_light_sample(ls, pmf, u); return ls; }
#endif
#if MCPT_LIGHT_AREA
    area_sample(ls, int(e.x), pmf, xo, u);
#endif
    return ls;
}

// What arrives along ls.wi (an area light's emission is read only for visible samples).
vec3 light_radiance(LightSample ls) {
#if MCPT_LIGHT_AREA
#if MCPT_EMISSION_TEXTURES
    if (light_is_area(ls)) return emission_at(material(tri_material(ls.tri)), ls.tri, ls.bary);
#else
    if (light_is_area(ls)) return material(tri_material(ls.tri)).emission;
#endif
#endif
    return ls.L;
}

// Nothing between xo and the light (an area light's point offset off its surface).
bool light_visible(LightSample ls, vec3 xo) {
    Ray r = Ray(xo, ls.wi);
    float tmax = ls.dist;
#if MCPT_LIGHT_AREA
    if (light_is_area(ls)) {
        vec3 seg = offset_ray(ls.y, ls.n) - xo;
        tmax = length(seg);
        r.d = seg / tmax;
    }
#endif
    return visible(r, tmax);
}

// Next-event estimation at a vertex with a non-delta lobe (bsdf_has_smooth): one light sample,
// its contribution added to P.L with the power heuristic's weight (weight 1 without MCPT_MIS and
// for delta lights). Shading frame as in path_step: ns for the BSDF, ng the geometric side, xo
// the offset origin.
void next_event(inout Path P, Material m, vec3 ns, vec3 ng, vec3 wo, vec3 xo, int dim) {
    LightSample ls = light_sample(xo, dim);
    float pdf_b;
    vec3 fc = bsdf_eval(m, ns, wo, ls.wi, pdf_b);
#if MCPT_SMOOTH_NORMALS || MCPT_NORMAL_MAPS
    if (dot(ng, ls.wi) <= 0.0) fc = vec3(0.0);  // below the real surface: no light leaks in
    fc *= normal_map_shadow(ls.wi);  // normal_map.glsl (1 without normal maps)
#endif
    if (ls.pdf > 0.0 && max(fc.r, max(fc.g, fc.b)) > 0.0) {
        if (light_visible(ls, xo)) {
            float w = 1.0;
#if MCPT_MIS
            if (!ls.delta) w = power_heuristic(ls.pdf, pdf_b);
#endif
#if MCPT_MEDIUM
            fc *= medium_tr(ls.dist);  // glsl/medium.glsl: the fog between xo and the light
#endif
            P.L += P.beta * fc * light_radiance(ls) * (w / ls.pdf);
        }
    }
}
#endif
