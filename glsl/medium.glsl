// A homogeneous participating medium filling the scene (issue #25; host side:
// mcpt/shading/medium.py): fog, haze, smoke. Coefficients per unit of world length, linear RGB:
// sigma_s scatters, sigma_a absorbs, sigma_t = sigma_a + sigma_s is the extinction; the phase
// function is Henyey-Greenstein (glsl/phase_hg.glsl). Compiled only when the scene has one
// (MCPT_MEDIUM).
//
// Along a ray, the distance to the next interaction is sampled from the transmittance
// Tr(t) = exp(-sigma_t t) of ONE colour channel c, picked uniformly, and weighted by the
// average over the channels of the density each would have given (single-sample MIS over the
// three channels, "spectral MIS": Miller, Georgiev & Jarosz 2019; pbrt-v4 VolPathIntegrator
// with a homogeneous majorant): the weight stays bounded where the channels differ, unlike
// Mitsuba 3 volpath's weight of the picked channel alone (src/integrators/volpath.cpp), which
// has the same mean. A scattering event at t < t_hit weighs sigma_s Tr(t) / mean_c(sigma_t,c
// Tr_c(t)); passing to the surface weighs Tr(t_hit) / mean_c Tr_c(t_hit).
#include "common.glsl"

uniform vec3 u_medium_sigma_t;  // extinction, 1 / world unit (RGB); 0: no scene-wide medium
uniform vec3 u_medium_sigma_s;  // scattering, 1 / world unit (RGB)
uniform float u_medium_g;       // Henyey-Greenstein mean cosine, in (-1, 1)

// A medium's coefficients: the scene's (id 0), a dielectric's interior (id i > 0) or vacuum (-1).
struct MediumCoeffs { vec3 sigma_t; vec3 sigma_s; float g; };

#if MCPT_MEDIUM_INTERIOR
// Interior media of closed dielectric meshes (mcpt/shading/medium.py interior_uniforms): the
// material whose meshes bound medium i + 1, and its coefficients.
#define MAX_MEDIA 8
uniform int u_media_count;
uniform int u_media_material[MAX_MEDIA];
uniform vec4 u_media_sigma_t[MAX_MEDIA];  // sigma_t.rgb, g
uniform vec3 u_media_sigma_s[MAX_MEDIA];
#endif

MediumCoeffs medium_coeffs(int id) {
    if (id < 0) return MediumCoeffs(vec3(0.0), vec3(0.0), 0.0);  // vacuum (inside clear glass)
#if MCPT_MEDIUM_INTERIOR
    if (id > 0) return MediumCoeffs(u_media_sigma_t[id - 1].rgb, u_media_sigma_s[id - 1], u_media_sigma_t[id - 1].w);
#endif
    return MediumCoeffs(u_medium_sigma_t, u_medium_sigma_s, u_medium_g);
}

// Transmittance over a distance t, world units (INF: none of it; a channel with sigma_t = 0: 1).
vec3 transmittance(vec3 sigma_t, float t) { return exp(-sigma_t * min(t, 3.0e38)); }

// ... of the scene's medium (shadow rays from surfaces: glass blocks them, so they cross no other).
vec3 medium_tr(float t) { return transmittance(u_medium_sigma_t, t); }

// Free-flight sampling in medium c along a ray whose surface hit (or INF) is t_hit away, with the
// uniform number u (dimension DIM_MEDIUM(k)): the distance to a scattering event (t < t_hit) or
// t_hit, and in w the throughput weight of that outcome (above). A medium that does not scatter
// (sigma_s = 0: Beer-Lambert absorption, as inside absorbing glass) weighs t_hit by its
// transmittance, no sampling.
float medium_distance(MediumCoeffs c, float t_hit, float u, out vec3 w) {
    if (max(c.sigma_s.r, max(c.sigma_s.g, c.sigma_s.b)) <= 0.0) {
        w = transmittance(c.sigma_t, t_hit);
        return t_hit;
    }
    float u3 = u * 3.0;
    int ch = min(int(u3), 2);
    float uc = u3 - float(ch);  // uniform in [0, 1) again, given the channel
    float st = ch == 0 ? c.sigma_t.r : (ch == 1 ? c.sigma_t.g : c.sigma_t.b);
    float t = st > 0.0 ? -log(1.0 - uc) / st : INF;
    if (t < t_hit) {
        vec3 tr = transmittance(c.sigma_t, t);
        float pdf = dot(c.sigma_t * tr, vec3(1.0 / 3.0));
        w = pdf > 0.0 ? c.sigma_s * tr / pdf : vec3(0.0);
        return t;
    }
    vec3 tr = transmittance(c.sigma_t, t_hit);
    float p = dot(tr, vec3(1.0 / 3.0));
    w = p > 0.0 ? tr / p : vec3(0.0);
    return t_hit;
}
