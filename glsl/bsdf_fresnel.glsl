// Exact Fresnel reflectance of a smooth dielectric interface for unpolarised light (the same
// formula as mcpt/shading/materials.py fresnel_dielectric). cos_i > 0 on the incident side; eta = n_t / n_i.
// Returns 1 under total internal reflection; cos_t is the cosine on the transmitted side.
float fresnel_dielectric(float cos_i, float eta, out float cos_t) {
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) { cos_t = 0.0; return 1.0; }
    cos_t = sqrt(1.0 - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}
