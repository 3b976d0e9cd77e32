// The Henyey-Greenstein phase function (host side: mcpt/shading/medium.py), parameter g in (-1, 1):
// the mean cosine between the direction light travelled and the one it scatters into (g > 0:
// forward). Normalised over the sphere, 1 / (4 pi) at g = 0:
//   p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^(3/2)),
// cos theta = dot(d_in, d_out) with both directions of travel (Mitsuba 3 src/phase/hg.cpp writes
// the same with wi pointing back, hence its "+ 2 g cos"). Sampled exactly by inverting its CDF
// (pbrt-v4 SampleHenyeyGreenstein), so the sample's weight p / pdf is 1.
#include "common.glsl"

float hg_eval(float cos_theta, float g) {
    float denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(max(denom, 1e-12)));
}

// A direction of travel after scattering from direction d (unit), u uniform in [0, 1)^2; pdf: its
// solid-angle density (= the phase function's value).
vec3 hg_sample(vec3 d, float g, vec2 u, out float pdf) {
    float cos_theta;
    if (abs(g) < 1e-4) {  // the inversion loses its digits: isotropic (p off by < 3e-4)
        cos_theta = 1.0 - 2.0 * u.x;
    } else {
        float s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
        cos_theta = (1.0 + g * g - s * s) / (2.0 * g);
    }
    cos_theta = clamp(cos_theta, -1.0, 1.0);
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float phi = 2.0 * PI * u.y;
    vec3 t, b;
    onb(d, t, b);
    pdf = hg_eval(cos_theta, g);
    return normalize(cos_theta * d + sin_theta * (cos(phi) * t + sin(phi) * b));
}
