// The environment: the light of rays that leave the scene (host side: mcpt/shading/environment.py).
// A constant environment (Mitsuba 3's `constant`): radiance u_env_radiance from every direction,
// sampled by next-event estimation uniformly over the sphere; or an environment map (Mitsuba 3's
// `envmap`, MCPT_ENVMAP: glsl/envmap.glsl evaluates and importance-samples it). Either is one
// entry of the light table, picked with probability u_env_pmf, found by escaping BSDF rays and
// weighted against the density NEE gives their direction by the power heuristic.
#if MCPT_ENVMAP
#include "envmap.glsl"
#else
uniform vec3 u_env_radiance;  // W sr^-1 m^-2, linear RGB
#endif
uniform float u_env_pmf;      // probability that light selection picks the environment (0: no NEE)
uniform int u_env_visible;    // 0: camera rays that escape see black (the scene is still lit)

const float INV_4PI = 0.07957747154594767;

// Radiance arriving along unit direction d (from -d's far end), and the solid-angle density
// with which env_light_sample produces d.
vec3 env_le_pdf(vec3 d, out float pdf) {
#if MCPT_ENVMAP
    return env_radiance_pdf(d, pdf);
#else
    pdf = INV_4PI;
    return u_env_radiance;
#endif
}

#if MCPT_NEE
// Uniform direction on the sphere (pbrt-v4 SampleUniformSphere).
vec3 sample_uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// The environment (picked with probability pmf) sampled with the numbers u.
void env_light_sample(inout LightSample ls, float pmf, vec2 u) {
    float pdf;
#if MCPT_ENVMAP
    ls.wi = env_sample_le(u, pdf, ls.L);
#else
    ls.wi = sample_uniform_sphere(u);
    ls.L = u_env_radiance;
    pdf = INV_4PI;
#endif
    ls.dist = INF;
    ls.pdf = pmf * pdf;
}
#endif

// P's ray (direction d) left the scene: the environment's radiance, MIS-weighted against NEE.
void env_escaped(inout Path P, vec3 d) {
    if (P.k == 1 && u_env_visible == 0) return;
    float pdf;
    vec3 le = env_le_pdf(d, pdf);
    P.L += P.beta * le * emitter_mis(P, u_env_pmf * pdf);
}
