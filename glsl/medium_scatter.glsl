// What a path does in the scene's medium (glsl/medium.glsl) on its way to hit k: pass through to
// the surface (or the sky), or scatter at a medium vertex, where it takes a light sample (phase
// function instead of BSDF, transmittance on the shadow ray: glsl/lights.glsl next_event) and a
// phase-function sample, combined by the power heuristic as at a surface (Veach 1997 ch. 9;
// Mitsuba 3 src/integrators/volpath.cpp). A medium vertex counts as a bounce (--bounces) and
// reads bounce k's random numbers as a surface vertex would: light choice and point, DIM_BSDF_UV
// for the phase direction, roulette; the free-flight distance has its own DIM_MEDIUM(k).
#include "medium.glsl"
#include "phase_hg.glsl"
#include "path_state.glsl"
#include "sampler.glsl"
#include "lights.glsl"
#include "roulette.glsl"
#if MCPT_AOV
#include "aov.glsl"
#endif
#if MCPT_MEDIUM_EQUIANGULAR
#include "medium_equiangular.glsl"
#endif

#define DIM_MEDIUM(k) (MCPT_DIM_MEDIUM + (k) - 1)
#define MEDIUM_PASS 0
#define MEDIUM_SCATTERED 1
#define MEDIUM_ENDED 2

#if MCPT_NEE
// Next-event estimation at the medium vertex x of medium c, t along P's ray (whose surface hit
// is t_hit away; d: its direction). Its shadow ray crosses medium c only: inside glass, the glass
// blocks it anyway.
void medium_next_event(inout Path P, MediumCoeffs c, vec3 x, float t, float t_hit, int dim) {
    vec3 d = P.ray.d;
    LightSample ls = light_sample(x, dim);
    if (ls.pdf <= 0.0) return;
    float ph = hg_eval(dot(d, ls.wi), c.g);
    if (light_visible(ls, x)) {
        float w = 1.0;
#if MCPT_MIS
        if (!ls.delta) w = power_heuristic(ls.pdf, ph);
#endif
#if MCPT_MEDIUM_EQUIANGULAR
        w *= equiangular_mis_free(c, P.ray.o, d, t_hit, t, ls, x);  // glsl/medium_equiangular.glsl
#endif
        P.L += P.beta * transmittance(c.sigma_t, ls.dist) * light_radiance(ls) * (ph * w / ls.pdf);
    }
}
#endif

// A scattering event of medium c at x, t along P's ray (vertex k = P.k): AOVs, a light sample,
// a phase-function sample (weight p / pdf = 1), roulette. False: the path ends.
bool medium_vertex(inout Path P, MediumCoeffs c, vec3 x, float t, float t_hit) {
    int k = P.k;
    vec3 d = P.ray.d;
#if MCPT_AOV
    if (k == 1) g_aov_a.a += t;
    if (P.aov_open) aov_event(P, c.sigma_s / max(c.sigma_t, vec3(1e-30)), vec3(0.0));
#endif
    if (max3(P.beta) <= 0.0) return false;
    int dim = DIM_BOUNCE(k);
#if MCPT_NEE
    medium_next_event(P, c, x, t, t_hit, dim);
#endif
    float pdf;
    vec3 wi = hg_sample(d, c.g, rand2_at(dim + DIM_BSDF_UV), pdf);
    P.pdf_bsdf_prev = pdf;
    P.delta_prev = false;
    P.ray = Ray(x, wi);
    P.k = k + 1;
    return roulette(P, k, dim);
}

// The medium the segment to hit h runs through: inside a dielectric (it arrives at its back, the
// rule of Beer-Lambert absorption, glsl/materials.glsl material_absorb) its interior medium, or
// vacuum (-1) for clear glass, as Mitsuba 3's medium tracking gives a shape without an interior;
// else the scene's (id 0).
int segment_medium(bool found, Hit h, vec3 d) {
#if MCPT_MAT_DIELECTRIC
    if (found && dot(hit_normal_raw(h), d) > 0.0) {
        int mat = tri_material(h.tri);
        if (int(texelFetch(u_materials, MCPT_MAT_TEXELS * mat).w) == MAT_DIELECTRIC) {
#if MCPT_MEDIUM_INTERIOR
            for (int i = 0; i < u_media_count; ++i) {
                if (u_media_material[i] == mat) return i + 1;
            }
#endif
            return -1;
        }
    }
#endif
    return 0;
}

// The segment from P.ray's origin to hit k = P.k (h: what it found, if found; else it leaves the
// scene). MEDIUM_PASS: P.beta carries the segment's weight, the surface (or sky) comes next as
// without a medium; MEDIUM_SCATTERED: P.ray is the next ray, for hit k + 1; MEDIUM_ENDED: the
// path is over. Beyond the bounce limit no vertex may scatter: the segment is weighted by its
// transmittance.
int medium_event(inout Path P, bool found, Hit h) {
    int k = P.k;
    float t_hit = found ? h.t : INF;
    MediumCoeffs c = medium_coeffs(segment_medium(found, h, P.ray.d));
    if (k > MCPT_BOUNCES) {
        P.beta *= transmittance(c.sigma_t, t_hit);
        return MEDIUM_PASS;
    }
#if MCPT_MEDIUM_EQUIANGULAR
    if (c.sigma_s != vec3(0.0)) equiangular_direct(P, c, t_hit, k);  // glsl/medium_equiangular.glsl
#endif
    vec3 w;
    float t = medium_distance(c, t_hit, rand_at(DIM_MEDIUM(k)), w);
    P.beta *= w;
    if (!(t < t_hit)) return MEDIUM_PASS;
    return medium_vertex(P, c, P.ray.o + t * P.ray.d, t, t_hit) ? MEDIUM_SCATTERED : MEDIUM_ENDED;
}
