// Conductor: a perfect mirror for alpha = 0, else a microfacet BRDF (bsdf_microfacet.glsl: GGX
// or Beckmann, height-correlated or separable masking)
//   f = F(wi.h) D(h) G2(wo, wi) / (4 cos_o cos_i)
// with the material's Fresnel mode (flags bits 1-2, mcpt/shading/materials.py), each times the
// lobe scale S (specular_reflectance):
//   Schlick: F = S (F0 + (1 - F0)(1 - cos)^5), F0 = the albedo (reflectance at normal incidence);
//   none:    F = S at every angle (Mitsuba's conductor with material "none": the reference mirror);
//   complex: F = S Fr(cos; eta + i k), the exact conductor Fresnel (bsdf_fresnel.glsl).
// A white conductor (F0 = 1 or mode none, S = 1) has F = 1: its mirror reflects everything, its
// rough version loses only what single-scattering GGX loses (masking).
#define FRESNEL_NONE 1u
#define FRESNEL_COMPLEX 2u

vec3 conductor_fresnel(Material m, float c) {
    uint mode = (m.flags >> 1) & 3u;
    if (mode == FRESNEL_NONE) return m.albedo;  // the albedo slot holds S (texturable)
#if MCPT_FRESNEL_COMPLEX
    if (mode == FRESNEL_COMPLEX) return m.albedo * fresnel_conductor(c, m.eta, m.k);
#endif
    return m.scale * fresnel_schlick(m.albedo, c);
}

vec3 conductor_eval(Material m, vec3 n, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
#if MCPT_MICROFACET
    if (m.alpha > 0.0) {
        vec3 t, b; local_frame(n, t, b);
        vec3 o = to_local(wo, t, b, n), i = to_local(wi, t, b, n);
        if (o.z <= 0.0 || i.z <= 0.0) return vec3(0.0);
        vec3 h = normalize(o + i);
        float lo = mf_lambda(o, m.alpha, m.flags), li = mf_lambda(i, m.alpha, m.flags);
        float d = mf_D(h, m.alpha, m.flags);
        pdf = d * mf_pdf_h_over_D(o, h, lo, m.flags) / (4.0 * dot(o, h));
        return conductor_fresnel(m, dot(i, h)) * (d * mf_G2(lo, li, m.flags) / (4.0 * o.z));
    }
#endif
    return vec3(0.0);  // a mirror has only a delta lobe
}

bool conductor_sample(Material m, vec3 n, vec3 wo, vec2 u, inout BsdfSample s) {
#if MCPT_MICROFACET
    if (m.alpha > 0.0) {
        vec3 t, b; local_frame(n, t, b);
        vec3 o = to_local(wo, t, b, n);
        if (o.z <= 0.0) return false;
        vec3 h = mf_sample(o, m.alpha, m.flags, u);
        float oh = dot(o, h);
        vec3 i = reflect(-o, h);
        if (i.z <= 0.0 || oh <= 0.0) return false;  // below the surface, or a back-facing facet
        float lo = mf_lambda(o, m.alpha, m.flags), li = mf_lambda(i, m.alpha, m.flags);
        float q = mf_pdf_h_over_D(o, h, lo, m.flags);
        s.wi = normalize(i.x * t + i.y * b + i.z * n);
        // f |cos| / pdf = F D G2 / (4 wo.z) / (D q / (4 wo.h)): for GGX's visible normals F G2 / G1.
        s.weight = conductor_fresnel(m, oh) * (mf_G2(lo, li, m.flags) * oh / (o.z * q));
        s.pdf = mf_D(h, m.alpha, m.flags) * q / (4.0 * oh);
        return true;
    }
#endif
    s.wi = reflect(-wo, n);
    s.weight = conductor_fresnel(m, dot(wo, n));
    s.pdf = 0.0;
    s.delta = true;
    return true;
}
