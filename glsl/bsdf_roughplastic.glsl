// Rough plastic, Mitsuba 3's roughplastic (src/bsdfs/roughplastic.cpp); host side and the model's
// formula: mcpt/shading/roughplastic.py. A rough dielectric coat (bsdf_microfacet.glsl; index
// m.ior) over a Lambertian base (m.albedo): the coat's reflection F D G2 / (4 cos_o), plus the
// base's light through the coat, A / (1 - K) (1 / pi) / eta^2 cos_i T(cos_o) T(cos_i), with
// K = A Fdr_int (flags bit 6, nonlinear) or Fdr_int, Fdr_int in m.fdr_int. T(mu), the coat's rough
// transmittance, is a 64-entry table in the material's last 16 texels (4 per texel), read by
// linear interpolation as Mitsuba's lerp_gather. Sampling as Mitsuba: the coat with probability
// ps = (1 - T(cos_o)) w / ((1 - T(cos_o)) w + T(cos_o) (1 - w)), w = 1 / (1 + mean(A)) (texel 3.x),
// else the cosine lobe; the weight is f |cos| over the mixture pdf of both lobes.
#define MAT_ROUGH_PLASTIC 6

float roughplastic_t(Material m, float mu) {
    float x = clamp(mu, 0.0, 1.0) * 63.0;
    int i = min(int(x), 62);
    int base = m.base + MCPT_MAT_TEXELS - 16;
    float v0 = uintBitsToFloat(texelFetch(u_materials, base + (i >> 2))[i & 3]);
    float v1 = uintBitsToFloat(texelFetch(u_materials, base + ((i + 1) >> 2))[(i + 1) & 3]);
    return mix(v0, v1, x - float(i));
}

// The probability of sampling the coat, for cos_o's transmittance t_o.
float roughplastic_p_coat(Material m, float t_o) {
    float w = m.scale.x;  // texel 3.x (material() reads texel 3 into sigma_a, scale and eta)
    float c = (1.0 - t_o) * w;
    return c / (c + t_o * (1.0 - w));
}

vec3 roughplastic_eval(Material m, vec3 n, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n), i = to_local(wi, t, b, n);
    if (o.z <= 0.0 || i.z <= 0.0) return vec3(0.0);
    vec3 h = normalize(o + i);
    float oh = dot(o, h);
    float lo = mf_lambda(o, m.alpha, m.flags), li = mf_lambda(i, m.alpha, m.flags);
    float d = mf_D(h, m.alpha, m.flags);
    float cos_t;
    float coat = fresnel_dielectric(oh, m.ior, cos_t) * d * mf_G2(lo, li, m.flags) / (4.0 * o.z);
    float t_o = roughplastic_t(m, o.z), t_i = roughplastic_t(m, i.z);
    vec3 k = (m.flags & MAT_FLAG_NONLINEAR) != 0u ? m.albedo * m.fdr_int : vec3(m.fdr_int);
    vec3 base = m.albedo / (1.0 - k) * (i.z * t_i * t_o / (PI * m.ior * m.ior));
    float p = roughplastic_p_coat(m, t_o);
    pdf = p * d * mf_pdf_h_over_D(o, h, lo, m.flags) / (4.0 * oh) + (1.0 - p) * i.z / PI;
    return vec3(coat) * SPEC_R(m) + base;  // Mitsuba's specular_reflectance on the coat (issue #22)
}

bool roughplastic_sample(Material m, vec3 n, vec3 wo, vec2 u, inout BsdfSample s) {
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n);
    if (o.z <= 0.0) return false;
    float p = roughplastic_p_coat(m, roughplastic_t(m, o.z));
    if (u.x < p) {
        vec3 h = mf_sample(o, m.alpha, m.flags, vec2(u.x / p, u.y));  // u.x rescaled (sample reuse)
        vec3 i = reflect(-o, h);
        if (i.z <= 0.0 || dot(o, h) <= 0.0) return false;
        s.wi = normalize(i.x * t + i.y * b + i.z * n);
    } else {
        float pc;
        s.wi = sample_cosine(n, vec2((u.x - p) / (1.0 - p), u.y), pc);
    }
    vec3 f = roughplastic_eval(m, n, wo, s.wi, s.pdf);
    if (s.pdf <= 0.0) return false;
    s.weight = f / s.pdf;
    return true;
}
