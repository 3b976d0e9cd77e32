// Equiangular sampling towards point and spot lights in a medium (Kulla & Fajardo 2012,
// "Importance Sampling Techniques for Path Tracing in Participating Media", sec. 4; host side:
// mcpt/shading/medium.py equiangular_used; MCPT_MEDIUM_EQUIANGULAR). Free-flight sampling puts
// medium vertices where the transmittance is, not where the light is: in thin fog lit by a spot,
// few vertices land in the light shaft and its glow converges slowly. Along every segment of the
// scene's medium, a distance t is also drawn with density proportional to 1 / (distance to the
// light)^2, q(t) = D / ((theta_b - theta_a) (D^2 + (t - delta)^2)), and the light's single
// scattering there is added, weighted by the power heuristic against the free-flight vertex's
// light sample (its density p(t) = the three channels' mean sigma_t Tr(t), glsl/medium.glsl).
// Both strategies pick the light with the same probability, which cancels in the weights.
#include "medium.glsl"
#include "phase_hg.glsl"
#include "lights.glsl"

#define DIM_EQUI(k) (MCPT_DIM_MEDIUM + MCPT_BOUNCES + (k) - 1)

// The segment o + t d, 0 <= t <= t_max, as the light at c sees it: delta, the distance along d
// to c's foot, D, c's distance from the line, and the angles of the ends (theta_a, theta_b).
vec4 equiangular_frame(vec3 o, vec3 d, float t_max, vec3 c) {
    float delta = dot(c - o, d);
    float D = max(length(c - o - delta * d), 1e-7);
    return vec4(delta, D, atan(-delta / D), atan((min(t_max, 1e30) - delta) / D));
}

// q(t) of the frame f.
float equiangular_pdf(vec4 f, float t) {
    float s = t - f.x;
    return f.y / ((f.w - f.z) * (f.y * f.y + s * s));
}

// A distance with density q(t) of the frame f, u uniform in [0, 1).
float equiangular_sample(vec4 f, float u) { return f.x + f.y * tan(mix(f.z, f.w, u)); }

// The free-flight density of a scattering event at t (glsl/medium.glsl medium_distance).
float free_flight_pdf(MediumCoeffs c, float t) {
    return dot(c.sigma_t * transmittance(c.sigma_t, t), vec3(1.0 / 3.0));
}

// MIS weight of the free-flight vertex at t on the segment (o, d, t_hit) for its light sample ls:
// a point or spot light (delta, at a finite distance) could also have come from equiangular sampling.
float equiangular_mis_free(MediumCoeffs c, vec3 o, vec3 d, float t_hit, float t, LightSample ls, vec3 x) {
    if (!ls.delta || !(ls.dist < INF)) return 1.0;
    float q = equiangular_pdf(equiangular_frame(o, d, t_hit, x + ls.dist * ls.wi), t);
    return power_heuristic(free_flight_pdf(c, t), q);
}

// The equiangular estimate of the single scattering of a point or spot light along P's ray up to
// t_hit in medium c, at bounce k (P.beta: the throughput at the segment's start).
void equiangular_direct(inout Path P, MediumCoeffs c, float t_hit, int k) {
    int dim = DIM_BOUNCE(k);
    float pmf;
    uvec4 e = light_pick(rand_at(dim + DIM_LIGHT_PICK), pmf);
    if (e.w != LIGHT_POINT && e.w != LIGHT_SPOT) return;
    vec3 o = P.ray.o, d = P.ray.d;
    vec4 f = equiangular_frame(o, d, t_hit, light_texel(int(e.x)).xyz);
    float t = clamp(equiangular_sample(f, rand_at(DIM_EQUI(k))), 0.0, min(t_hit, 1e30));
    vec3 x = o + t * d;
    LightSample ls;
    ls.tri = -1;
    punctual_sample(ls, e, pmf, x, vec2(0.0));
    float q = equiangular_pdf(f, t);
    float ph = hg_eval(dot(d, ls.wi), c.g);
    if (!(q > 0.0) || ph * max3(ls.L) <= 0.0 || !visible(Ray(x, ls.wi), ls.dist)) return;
    float w = power_heuristic(q, free_flight_pdf(c, t));
    vec3 tr = transmittance(c.sigma_t, t) * transmittance(c.sigma_t, ls.dist);
    P.L += P.beta * tr * c.sigma_s * ls.L * (ph * w / (pmf * q));
}
