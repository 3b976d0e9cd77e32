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

uniform vec3 u_medium_sigma_t;  // extinction, 1 / world unit (RGB)
uniform vec3 u_medium_sigma_s;  // scattering, 1 / world unit (RGB)
uniform float u_medium_g;       // Henyey-Greenstein mean cosine, in (-1, 1)

// Transmittance over a distance t, world units (INF: none of it; a channel with sigma_t = 0: 1).
vec3 medium_tr(float t) { return exp(-u_medium_sigma_t * min(t, 3.0e38)); }

// Free-flight sampling along a ray whose surface hit (or INF) is t_hit away, with the uniform
// number u (dimension DIM_MEDIUM(k)): the distance to a scattering event (t < t_hit) or t_hit,
// and in w the throughput weight of that outcome (above).
float medium_distance(float t_hit, float u, out vec3 w) {
    float u3 = u * 3.0;
    int c = min(int(u3), 2);
    float uc = u3 - float(c);  // uniform in [0, 1) again, given the channel
    float st = c == 0 ? u_medium_sigma_t.r : (c == 1 ? u_medium_sigma_t.g : u_medium_sigma_t.b);
    float t = st > 0.0 ? -log(1.0 - uc) / st : INF;
    if (t < t_hit) {
        vec3 tr = medium_tr(t);
        float pdf = dot(u_medium_sigma_t * tr, vec3(1.0 / 3.0));
        w = pdf > 0.0 ? u_medium_sigma_s * tr / pdf : vec3(0.0);
        return t;
    }
    vec3 tr = medium_tr(t_hit);
    float p = dot(tr, vec3(1.0 / 3.0));
    w = p > 0.0 ? tr / p : vec3(0.0);
    return t_hit;
}
