// Plastic: a Lambertian base of albedo A under a smooth dielectric coat of index eta (Mitsuba 3's
// plastic, src/bsdfs/plastic.cpp, either `nonlinear` mode):
//   specular: a mirror reflection with the coat's Fresnel reflectance Fo = F(cos_o);
//   diffuse:  f = A / (pi (1 - K)) (1 - Fo)(1 - Fi) / eta^2,
// where light crossing the coat is scattered by the base, partly reflected back by the coat
// from inside (Fdr_int, mcpt/shading/materials.py) and scattered again: the geometric series gives
// K = A Fdr_int (flags bit 6, nonlinear: mcpt's default) or, Mitsuba's default, K = Fdr_int. For a
// white base the two lobes reflect exactly all light in both modes (1 - Fdr_int =
// (1 - Fdr_ext) / eta^2). The lobe is picked by u.x with probability Ps for the specular one.

// Probability of picking the specular lobe, Mitsuba's rule: Fo w / (Fo w + (1 - Fo)(1 - w)) with
// w = 1 / (1 + mean(A)). The coat is picked more often than its share of the reflectance
// (Fo / (Fo + (1 - Fo) max3(A)), mcpt's rule before): its samples are the ones that find small
// bright lights through a delta lobe, so its weight Fo / ps is what makes fireflies, while the
// diffuse lobe is also reached by light sampling. Issue #21 "Variance" (bench/plastic_variance.py,
// README "Variance on the material preview"): mcpt relMSE -21 % (+-7 %) at 64 spp there.
float plastic_spec_prob(Material m, float Fo) {
    float w = 1.0 / (1.0 + (m.albedo.r + m.albedo.g + m.albedo.b) * (1.0 / 3.0));
    float s = Fo * w;
    return s / max(s + (1.0 - Fo) * (1.0 - w), 1e-20);
}

vec3 plastic_diffuse(Material m, float Fo, float Fi) {
    vec3 k = (m.flags & MAT_FLAG_NONLINEAR) != 0u ? m.albedo * m.fdr_int : vec3(m.fdr_int);
    return m.albedo * (INV_PI * (1.0 - Fo) * (1.0 - Fi) / (m.ior * m.ior)) / (1.0 - k);
}

vec3 plastic_eval(Material m, vec3 n, vec3 wo, vec3 wi, out float pdf) {
    float cos_o = dot(wo, n), cos_i = dot(wi, n), ct;
    pdf = 0.0;
    if (cos_i <= 0.0) return vec3(0.0);
    float Fo = fresnel_dielectric(cos_o, m.ior, ct);
    float Fi = fresnel_dielectric(cos_i, m.ior, ct);
    pdf = (1.0 - plastic_spec_prob(m, Fo)) * cos_i * INV_PI;
    return plastic_diffuse(m, Fo, Fi) * cos_i;
}

bool plastic_sample(Material m, vec3 n, vec3 wo, vec2 u, inout BsdfSample s) {
    float cos_o = dot(wo, n), ct;
    float Fo = fresnel_dielectric(cos_o, m.ior, ct);
    float ps = plastic_spec_prob(m, Fo);
    if (u.x < ps) {
        s.wi = 2.0 * cos_o * n - wo;
        s.weight = vec3(Fo / ps) * SPEC_R(m);  // Mitsuba's specular_reflectance (issue #22)
        s.pdf = 0.0;
        s.delta = true;
        return true;
    }
    // Reuse u.x: given u.x >= ps it is uniform on [ps, 1); rescaled it is uniform on [0, 1).
    u.x = min((u.x - ps) / (1.0 - ps), 0.99999994);
    float pdf_c;
    s.wi = sample_cosine(n, u, pdf_c);
    float Fi = fresnel_dielectric(dot(s.wi, n), m.ior, ct);
    // f cos / ((1 - ps) cos / pi)
    s.weight = plastic_diffuse(m, Fo, Fi) * (PI / (1.0 - ps));
    s.pdf = (1.0 - ps) * pdf_c;
    return true;
}
