// The environment: the light of rays that leave the scene (host side: mcpt/shading/environment.py).
// A constant environment (Mitsuba 3's `constant`): radiance u_env_radiance from every direction,
// sampled by next-event estimation uniformly over the sphere (one entry of the light table,
// picked with probability u_env_pmf), found by escaping BSDF rays and weighted against that
// density by the power heuristic.
uniform vec3 u_env_radiance;  // W sr^-1 m^-2, linear RGB
uniform float u_env_pmf;      // probability that light selection picks the environment (0: no NEE)
uniform int u_env_visible;    // 0: camera rays that escape see black (the scene is still lit)

const float INV_4PI = 0.07957747154594767;

// Solid-angle density with which NEE produces direction d (given the environment was picked).
float env_dir_pdf(vec3 d) { return INV_4PI; }

#if MCPT_NEE
// Uniform direction on the sphere (pbrt-v4 SampleUniformSphere).
vec3 sample_uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

void env_light_sample(inout LightSample ls, float pmf, vec2 u) {
    ls.wi = sample_uniform_sphere(u);
    ls.dist = INF;
    ls.L = u_env_radiance;
    ls.pdf = pmf * env_dir_pdf(ls.wi);
}
#endif

// P's ray (direction d) left the scene: the environment's radiance, MIS-weighted against NEE.
void env_escaped(inout Path P, vec3 d) {
    if (P.k == 1 && u_env_visible == 0) return;
    P.L += P.beta * u_env_radiance * emitter_mis(P, u_env_pmf * env_dir_pdf(d));
}
