// Smooth dielectric (glass): reflect with the exact Fresnel probability F, else refract by
// Snell's law (total internal reflection: F = 1). Both lobes are deltas, chosen with u: the
// weights are F / F = 1 and (1 - F) / (1 - F) / eta^2 -- radiance is compressed into the
// smaller solid angle on the denser side (Veach 1997, 5.2), and expands back on the way out.
// The front side of the mesh is the outside (air, index 1).

bool dielectric_sample(Material m, vec3 n, vec3 wo, bool front, float u, inout BsdfSample s) {
    float eta = front ? m.ior : 1.0 / m.ior;  // n_t / n_i across the surface
    float cos_o = dot(wo, n);
    float cos_t;
    float F = fresnel_dielectric(cos_o, eta, cos_t);
    s.delta = true;
    s.pdf = 0.0;
    if (u < F) {
        s.wi = 2.0 * cos_o * n - wo;
        s.weight = SPEC_R(m);  // Mitsuba's specular_reflectance (issue #22): the lobe choice stays F
    } else {
        s.wi = normalize((cos_o / eta - cos_t) * n - wo / eta);
        s.weight = vec3(1.0 / (eta * eta)) * SPEC_T(m);  // and its specular_transmittance
        s.transmit = true;
        s.eta2 = eta * eta;
    }
    return true;
}
