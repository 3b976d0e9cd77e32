// Fresnel factors. Host-side twins: mcpt/shading/materials.py (dielectric); the conductor's is
// checked against an independent complex-arithmetic numpy version (tests/test_conductor.py).

// Exact Fresnel reflectance of a smooth dielectric interface for unpolarised light (the same
// formula as mcpt/shading/materials.py fresnel_dielectric). cos_i > 0 on the incident side; eta = n_t / n_i.
// Returns 1 under total internal reflection; cos_t is the cosine on the transmitted side.
float fresnel_dielectric(float cos_i, float eta, out float cos_t) {
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) { cos_t = 0.0; return 1.0; }
    cos_t = sqrt(1.0 - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return min(0.5 * (rs * rs + rp * rp), 1.0);  // inexact GPU division: never above 1 (see below)
}

// Schlick's approximation, F0 + (1 - F0)(1 - cos)^5 (Schlick 1994).
vec3 fresnel_schlick(vec3 f0, float c) {
    float m = clamp(1.0 - c, 0.0, 1.0);
    float m2 = m * m;
    return f0 + (1.0 - f0) * (m2 * m2 * m);
}

#if MCPT_FRESNEL_COMPLEX
// Exact unpolarised Fresnel reflectance of a conductor with complex index eta + i k (relative to
// the outside), per RGB channel: the function pbrt-v4 computes with complex numbers (FrComplex,
// 0.5 (|r_par|^2 + |r_perp|^2)), written in real arithmetic as Mitsuba 3 does (fresnel_conductor,
// after K. D. Moeller, "Optics", 1988): with a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2)
// and a = sqrt((a^2 + b^2 + eta^2 - k^2 - sin^2) / 2),
//   Rs = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos),
//   Rp = Rs ((a^2 + b^2) cos^2 + sin^4 - 2 a cos sin^2) / ((a^2 + b^2) cos^2 + sin^4 + 2 a cos sin^2).
// Three channels in one vec3 (llvmpipe runs it as one SIMD sequence), no complex square root.
vec3 fresnel_conductor(float cos_i, vec3 eta, vec3 k) {
    precise float c = clamp(cos_i, 0.0, 1.0);
    precise float c2 = c * c, s2 = 1.0 - c2, s4 = s2 * s2;
    precise vec3 t1 = eta * eta - k * k - s2;
    precise vec3 ek2 = eta * eta * k * k;
    precise vec3 a2pb2 = sqrt(t1 * t1 + 4.0 * ek2);
    // a^2 = (a^2 + b^2 + t1) / 2 cancels where t1 < 0 (eta < sin, k small: near total internal
    // reflection); there the equal 2 eta^2 k^2 / (a^2 + b^2 - t1) is exact in float32.
    precise vec3 a2 = mix(2.0 * ek2 / max(a2pb2 - t1, 1e-30), 0.5 * (a2pb2 + t1), greaterThanEqual(t1, vec3(0.0)));
    precise vec3 a = sqrt(a2);
    precise vec3 term1 = a2pb2 + c2, term2 = 2.0 * c * a;
    precise vec3 rs = (term1 - term2) / (term1 + term2);
    precise vec3 term3 = a2pb2 * c2 + s4, term4 = term2 * s2;
    precise vec3 rp = rs * (term3 - term4) / (term3 + term4);
    // GLSL division need not be correctly rounded (2.5 ulp allowed; NVIDIA's is not exact): at
    // grazing cosines, where rs = rp = 1, an H100 returned 1 + 1 ulp. A reflectance above 1 would
    // add energy: clamped (the error stays at rounding; inputs here are finite).
    return clamp(0.5 * (rs + rp), 0.0, 1.0);
}
#endif
