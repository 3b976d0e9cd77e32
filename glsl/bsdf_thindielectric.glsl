// Thin dielectric (a window pane: two parallel interfaces close together), as Mitsuba 3's
// thindielectric (src/bsdfs/thindielectric.cpp); host side: mcpt/shading/thindielectric.py. Light
// leaves unrefracted: reflected about n, or straight through (wi = -wo, no offset, no eta). The
// internal reflections between the two faces are summed: with R the Fresnel reflectance of one
// face at the incident angle (index m.ior, either side alike) and T = 1 - R,
//   R' = R + T^2 R (1 + R^2 + R^4 + ...) = R + T^2 R / (1 - R^2) = 2R / (1 + R),   T' = 1 - R'.
// Both lobes are deltas, picked with probability R' / T': every sample weighs 1.
#define MAT_THIN_DIELECTRIC 5

bool thindielectric_sample(Material m, vec3 n, vec3 wo, float u, inout BsdfSample s) {
    float cos_o = dot(wo, n);
    float cos_t;
    float r = fresnel_dielectric(cos_o, m.ior, cos_t);
    s.delta = true;
    s.pdf = 0.0;
    if (u < 2.0 * r / (1.0 + r)) {
        s.wi = 2.0 * cos_o * n - wo;
        s.weight = SPEC_R(m);  // Mitsuba's specular_reflectance / _transmittance (issue #22)
    } else {
        s.wi = -wo;
        s.weight = SPEC_T(m);
        s.transmit = true;
    }
    return true;
}
