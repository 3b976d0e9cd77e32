// GGX (Trowbridge-Reitz) microfacet distribution, isotropic, in a local frame with the normal
// along +z. Smith masking, height-correlated (Heitz 2014, "Understanding the Masking-Shadowing
// Function"); visible-normal sampling by spherical caps (Dupuy & Benyoub 2023, "Sampling Visible
// GGX Normals with Spherical Caps"), which draws exactly D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z.

// D(h) written with h.xy directly: the textbook 1 + (a^2 - 1) cos^2 form cancels catastrophically
// near the peak for small alpha in float32.
float ggx_D(vec3 h, float a) {
    float a2 = a * a;
    float k = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
    return 1.0 / (PI * a2 * k * k);
}

// Smith Lambda; x / (1 + sqrt(1 + x)) is (sqrt(1 + x) - 1) without the cancellation.
float ggx_lambda(vec3 w, float a) {
    float x = a * a * (w.x * w.x + w.y * w.y) / (w.z * w.z);
    return 0.5 * x / (1.0 + sqrt(1.0 + x));
}

// A visible microfacet normal for wo (wo.z > 0), u uniform in [0, 1)^2.
vec3 ggx_sample_vndf(vec3 wo, float a, vec2 u) {
    vec3 v = normalize(vec3(a * wo.xy, wo.z));          // the view direction, stretched
    float phi = 2.0 * PI * u.x;
    float z = (1.0 - u.y) * (1.0 + v.z) - v.z;           // uniform on the spherical cap
    float st = sqrt(max(0.0, 1.0 - z * z));
    vec3 h = vec3(st * cos(phi), st * sin(phi), z) + v;  // on the hemisphere, visible from v
    return normalize(vec3(a * h.xy, max(h.z, 0.0)));     // unstretched
}

void local_frame(vec3 n, out vec3 t, out vec3 b) { onb(n, t, b); }
vec3 to_local(vec3 w, vec3 t, vec3 b, vec3 n) { return vec3(dot(w, t), dot(w, b), dot(w, n)); }
