// The microfacet model a rough material uses (host side: mcpt/shading/microfacet.py): which
// distribution (GGX, bsdf_ggx.glsl; Beckmann, bsdf_beckmann.glsl: flags bit 4) and which Smith
// masking-shadowing term (flags bit 5):
//   height-correlated (default; Heitz 2014, eq. 99): G2 = 1 / (1 + Lambda(wo) + Lambda(wi)),
//   separable (Mitsuba 3's MicrofacetDistribution::G): G2 = G1(wo) G1(wi).
// The two agree up to ~45 degrees; the separable one is darker at grazing angles (it ignores
// that a facet hidden from one direction tends to be hidden from the other). Each choice is
// compiled only when some material makes it (MCPT_BECKMANN, MCPT_SEPARABLE_MASKING).
#define MAT_FLAG_BECKMANN 16u
#define MAT_FLAG_SEPARABLE 32u

bool mf_beckmann(uint flags) {
#if MCPT_BECKMANN
    return (flags & MAT_FLAG_BECKMANN) != 0u;
#else
    return false;
#endif
}

float mf_D(vec3 h, float a, uint flags) {
#if MCPT_BECKMANN
    if (mf_beckmann(flags)) return beckmann_D(h, a);
#endif
    return ggx_D(h, a);
}

float mf_lambda(vec3 w, float a, uint flags) {
#if MCPT_BECKMANN
    if (mf_beckmann(flags)) return beckmann_lambda(w, a);
#endif
    return ggx_lambda(w, a);
}

// A microfacet normal for wo (wo.z > 0): GGX's visible normals, Beckmann's D(h) cos(h).
vec3 mf_sample(vec3 wo, float a, uint flags, vec2 u) {
#if MCPT_BECKMANN
    if (mf_beckmann(flags)) return beckmann_sample(a, u);
#endif
    return ggx_sample_vndf(wo, a, u);
}

// The density of h as mf_sample draws it, divided by D(h) (so that weights need no D):
// GGX visible normals G1(wo) max(0, wo.h) / wo.z; Beckmann h.z.
float mf_pdf_h_over_D(vec3 wo, vec3 h, float lambda_o, uint flags) {
#if MCPT_BECKMANN
    if (mf_beckmann(flags)) return h.z;
#endif
    return max(dot(wo, h), 0.0) / (wo.z * (1.0 + lambda_o));
}

float mf_G2(float lambda_o, float lambda_i, uint flags) {
#if MCPT_SEPARABLE_MASKING
    if ((flags & MAT_FLAG_SEPARABLE) != 0u) return 1.0 / ((1.0 + lambda_o) * (1.0 + lambda_i));
#endif
    return 1.0 / (1.0 + lambda_o + lambda_i);
}
