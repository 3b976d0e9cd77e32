// Beckmann microfacet distribution, isotropic, local frame with the normal along +z (host side:
// mcpt/shading/microfacet.py). Mitsuba 3's formulas (include/mitsuba/render/microfacet.h):
//   D(h) = exp(-tan^2 / a^2) / (pi a^2 cos^4)
//   G1(w) = 1 / (1 + Lambda(w)) by Walter et al. 2007's rational fit (eq. 27, < 0.35 % error),
//   with b = 1 / (a tan theta): Lambda = (1 - 1.259 b + 0.396 b^2) / (3.535 b + 2.181 b^2), 0 for
//   b >= 1.6 -- the exact G1 Mitsuba evaluates, so converted scenes mask alike.
// Sampled from D(h) cos(h) (Walter et al. 2007, eq. 28; Mitsuba with sample_visible = false):
// tan^2 = -a^2 ln(1 - u). Mitsuba's default draws visible normals instead; both are unbiased,
// they differ in variance only.

float beckmann_D(vec3 h, float a) {
    float c2 = h.z * h.z;
    float t2 = (h.x * h.x + h.y * h.y) / c2;
    return exp(-t2 / (a * a)) / (PI * a * a * c2 * c2);
}

float beckmann_lambda(vec3 w, float a) {
    float s = sqrt(w.x * w.x + w.y * w.y);
    float b = abs(w.z) / (a * max(s, 1e-30));  // |w.z|: refracted directions point down
    if (b >= 1.6) return 0.0;
    return (1.0 - 1.259 * b + 0.396 * b * b) / (3.535 * b + 2.181 * b * b);
}

vec3 beckmann_sample(float a, vec2 u) {
    float t2 = -a * a * log(1.0 - u.x);
    float c = inversesqrt(1.0 + t2);
    float st = sqrt(max(0.0, 1.0 - c * c));
    float phi = 2.0 * PI * u.y;
    return vec3(st * cos(phi), st * sin(phi), c);
}
