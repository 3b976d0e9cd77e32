// Lambertian BSDF, two-sided: n is the geometric normal flipped to the side the path came from.
// f = albedo / pi; cosine-weighted sampling, pdf = cos / pi, so f cos / pdf = albedo.

vec3 sample_cosine(vec3 n, vec2 u, out float pdf) {
    // Malley's method: uniform disk (polar), projected up.
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float z = sqrt(max(0.0, 1.0 - u.x));
    vec3 t, b; onb(n, t, b);
    pdf = z * INV_PI;
    return normalize(r * cos(phi) * t + r * sin(phi) * b + z * n);
}

// f * cos for a light direction wi (unit), zero below the surface.
vec3 diffuse_eval(vec3 albedo, vec3 n, vec3 wi) { return albedo * (max(dot(n, wi), 0.0) * INV_PI); }
float diffuse_pdf(vec3 n, vec3 wi) { return max(dot(n, wi), 0.0) * INV_PI; }
