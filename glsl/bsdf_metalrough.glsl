// glTF 2.0's metal-rough material exactly as the glTF 2.0 specification's appendix B writes it
// (B.3: "BRDF implementation"); host side and the formula's float64 twin: mcpt/shading/metalrough.py.
//   f = mix(dielectric_brdf, metal_brdf, metallic)
//   metal_brdf      = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(alpha))
//   dielectric_brdf = fresnel_mix(ior 1.5, base = diffuse_brdf(baseColor), layer = specular_brdf(alpha))
// with specular_brdf = D V (GGX D, Smith V = G2 / (4 |n.l| |n.v|); G2 by bsdf_microfacet.glsl's
// masking choice, height-correlated by default), Schlick's Fresnel of v.h: conductor f0 + (1 - f0)
// (1 - |v.h|)^5, fresnel_mix: mix(base, layer, F) with f0 = ((1 - ior) / (1 + ior))^2 = 0.04.
// alpha = roughness^2 (m.alpha, floored at MIN_ALPHA by the host); metallic in texel 3.x (m.scale.x).
// Sampling: the specular lobe (GGX visible normals) with probability p, else the cosine lobe;
// p = s / (s + d) from the lobes' weights at the view angle (s: Schlick at cos_o mixed by metallic,
// d: (1 - metallic) (1 - F_0.04(cos_o)) mean(baseColor)); the pdf is both lobes' mixture (MIS).
// MCPT_METALROUGH_SPECULAR (KHR_materials_ior / _specular, issue #21 item 5): the dielectric's
// Schlick F = F0 + (F90 - F0) (1 - |v.h|)^5 with F0 (rgb), F90 from the table (m.mr_f0, m.mr_f90),
// the base weighted by 1 - max(F) (the extension's fresnel_mix); d above uses 1 - max(F(cos_o)).
// Without it, the code below is exactly the plain appendix-B material's (F0 0.04, F90 1).
#define MAT_METALROUGH 7

float metalrough_schlick_w(float c) { float x = clamp(1.0 - c, 0.0, 1.0); float x2 = x * x; return x2 * x2 * x; }

// The probability of sampling the specular lobe at cos_o.
float metalrough_p_spec(Material m, float cos_o) {
    float met = m.scale.x, w = metalrough_schlick_w(cos_o);
    vec3 fm = m.albedo + (1.0 - m.albedo) * w;
#if MCPT_METALROUGH_SPECULAR
    vec3 fr = m.mr_f0 + (m.mr_f90 - m.mr_f0) * w;
    float s = mix((fr.r + fr.g + fr.b) / 3.0, (fm.r + fm.g + fm.b) / 3.0, met);
    float d = (1.0 - met) * (1.0 - max3(fr)) * (m.albedo.r + m.albedo.g + m.albedo.b) / 3.0;
#else
    float fd = 0.04 + 0.96 * w;
    float s = mix(fd, (fm.r + fm.g + fm.b) / 3.0, met);
    float d = (1.0 - met) * (1.0 - fd) * (m.albedo.r + m.albedo.g + m.albedo.b) / 3.0;
#endif
    return s + d > 0.0 ? s / (s + d) : 1.0;
}

vec3 metalrough_eval(Material m, vec3 n, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n), i = to_local(wi, t, b, n);
    if (o.z <= 0.0 || i.z <= 0.0) return vec3(0.0);
    vec3 h = normalize(o + i);
    float oh = dot(o, h);
    float lo = mf_lambda(o, m.alpha, m.flags), li = mf_lambda(i, m.alpha, m.flags);
    float d = mf_D(h, m.alpha, m.flags);
    float spec = d * mf_G2(lo, li, m.flags) / (4.0 * o.z);  // specular_brdf |cos_i|
    float met = m.scale.x, w = metalrough_schlick_w(abs(oh));
    vec3 fm = m.albedo + (1.0 - m.albedo) * w;             // conductor_fresnel, f0 = baseColor
#if MCPT_METALROUGH_SPECULAR
    vec3 fr = m.mr_f0 + (m.mr_f90 - m.mr_f0) * w;          // fresnel_mix's weight x Schlick (extensions)
    vec3 f = spec * mix(fr, fm, met) + (1.0 - met) * (1.0 - max3(fr)) * m.albedo * (i.z / PI);
#else
    float fd = 0.04 + 0.96 * w;                            // fresnel_mix's Schlick, ior 1.5
    vec3 f = spec * mix(vec3(fd), fm, met) + (1.0 - met) * (1.0 - fd) * m.albedo * (i.z / PI);
#endif
    float p = metalrough_p_spec(m, o.z);
    pdf = p * d * mf_pdf_h_over_D(o, h, lo, m.flags) / (4.0 * oh) + (1.0 - p) * i.z / PI;
    return f;
}

bool metalrough_sample(Material m, vec3 n, vec3 wo, vec2 u, inout BsdfSample s) {
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n);
    if (o.z <= 0.0) return false;
    float p = metalrough_p_spec(m, o.z);
    if (u.x < p) {
        vec3 h = mf_sample(o, m.alpha, m.flags, vec2(u.x / p, u.y));  // u.x rescaled (sample reuse)
        vec3 i = reflect(-o, h);
        if (i.z <= 0.0 || dot(o, h) <= 0.0) return false;
        s.wi = normalize(i.x * t + i.y * b + i.z * n);
    } else {
        float pc;
        s.wi = sample_cosine(n, vec2((u.x - p) / (1.0 - p), u.y), pc);
    }
    vec3 f = metalrough_eval(m, n, wo, s.wi, s.pdf);
    if (s.pdf <= 0.0) return false;
    s.weight = f / s.pdf;
    return true;
}
