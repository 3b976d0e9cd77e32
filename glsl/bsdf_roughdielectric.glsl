// Rough dielectric interface (Walter et al. 2007, "Microfacet Models for Refraction through Rough
// Surfaces"), as Mitsuba 3's roughdielectric (src/bsdfs/roughdielectric.cpp); host side:
// mcpt/shading/roughdielectric.py (its float64 twin). Microfacets of either distribution and
// masking term (bsdf_microfacet.glsl); local frame with n on the side of wo (o.z > 0); eta = m.ior
// after material_side(): n (the other side) / n (wo's side). With h the (generalised) half vector
// of o and i, F = Fresnel(o.h, eta), D, G2:
//   reflection (i.z > 0):  f |cos i| = F D G2 / (4 o.z)
//   refraction (i.z < 0):  f |cos i| = (1 - F) D G2 |o.h| |i.h| / (o.z (o.h + eta i.h)^2)
// (radiance: Walter's eta^2 times the 1/eta^2 of the solid-angle compression, Mitsuba's "missing
// term"). Sampling draws h (GGX visible normals; Beckmann D cos), then reflects with probability
// F(o.h) -- the Fresnel of the sampled microfacet, Mitsuba's choice -- else refracts; facets seen
// from behind (o.h <= 0, or i on the wrong side of h) are masked, so energy lost at grazing
// angles is the single-scattering loss Mitsuba has too.
//
// Light sampling covers the reflected lobe only: next_event (lights.glsl) starts shadow rays on
// wo's side, where a light behind the interface is hidden by the surface itself. The refracted
// lobe is therefore reached by BSDF sampling alone, flagged `delta` so that an emitter it hits
// counts with weight 1 (the MIS pair is complete; unbiased, noisier for small lights behind).
#define MAT_ROUGH_DIELECTRIC 4

// f |cos wi| (white) and the sampling pdf of wi; `with_t`: include the refracted lobe.
vec3 roughdielectric_eval(Material m, vec3 n, vec3 wo, vec3 wi, bool with_t, out float pdf) {
    pdf = 0.0;
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n), i = to_local(wi, t, b, n);
    bool refl = i.z > 0.0;
    if (o.z <= 0.0 || i.z == 0.0 || (!refl && !with_t)) return vec3(0.0);
    float eta = m.ior;
    vec3 h = normalize(o + i * (refl ? 1.0 : eta));
    h = h.z < 0.0 ? -h : h;  // on the macrosurface's side
    float oh = dot(o, h), ih = dot(i, h);
    if (oh <= 0.0 || ih * i.z <= 0.0) return vec3(0.0);  // a facet seen from behind: masked
    float lo = mf_lambda(o, m.alpha, m.flags), li = mf_lambda(i, m.alpha, m.flags);
    float dg = mf_D(h, m.alpha, m.flags) * mf_G2(lo, li, m.flags);
    float q = mf_D(h, m.alpha, m.flags) * mf_pdf_h_over_D(o, h, lo, m.flags);  // density of h
    float cos_t;
    float F = fresnel_dielectric(oh, eta, cos_t);
    if (refl) {
        pdf = q * F / (4.0 * ih);
        return vec3(F * dg / (4.0 * o.z)) * SPEC_R(m);  // Mitsuba's specular_reflectance (issue #22)
    }
    float den = oh + eta * ih;
    den *= den;
    pdf = q * (1.0 - F) * eta * eta * -ih / den;
    return vec3((1.0 - F) * dg * oh * -ih / (o.z * den)) * SPEC_T(m);  // and specular_transmittance
}

// u.xy: the microfacet normal, u.z: reflect (u.z < F) or refract.
bool roughdielectric_sample(Material m, vec3 n, vec3 wo, vec3 u, inout BsdfSample s) {
    vec3 t, b; local_frame(n, t, b);
    vec3 o = to_local(wo, t, b, n);
    if (o.z <= 0.0) return false;
    float eta = m.ior;
    vec3 h = mf_sample(o, m.alpha, m.flags, u.xy);
    float oh = dot(o, h);
    if (oh <= 0.0) return false;  // Beckmann's D cos draws back-facing facets too
    float lo = mf_lambda(o, m.alpha, m.flags);
    float qd = mf_pdf_h_over_D(o, h, lo, m.flags), q = mf_D(h, m.alpha, m.flags) * qd;
    float cos_t;
    float F = fresnel_dielectric(oh, eta, cos_t);
    vec3 i;
    float w;
    vec3 c = SPEC_R(m);  // issue #22: the lobe's factor (the lobe choice stays F)
    if (u.z < F) {
        i = 2.0 * oh * h - o;
        if (i.z <= 0.0) return false;
        s.pdf = q * F / (4.0 * oh);
        w = oh / (o.z * qd);                 // f |cos| / pdf = G2 o.h / (o.z qd), G2 below
    } else {
        i = normalize((oh / eta - cos_t) * h - o / eta);
        if (i.z >= 0.0) return false;
        float ih = dot(i, h), den = oh + eta * ih;
        s.pdf = q * (1.0 - F) * eta * eta * -ih / (den * den);
        w = oh / (o.z * qd * eta * eta);     // radiance is compressed by 1/eta^2
        s.transmit = true;
        s.eta2 = eta * eta;
        s.delta = true;                      // not light-sampled (see above)
        c = SPEC_T(m);
    }
    s.weight = vec3(w * mf_G2(lo, mf_lambda(i, m.alpha, m.flags), m.flags)) * c;
    s.wi = normalize(i.x * t + i.y * b + i.z * n);
    return true;
}
