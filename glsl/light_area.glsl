// Area lights: emissive triangles (host side: the area entries of mcpt/shading/lights.py), sampled by
// next-event estimation (glsl/lights.glsl). An entry's payload is its triangle, picked with
// probability proportional to emitted power x area; a point is then sampled uniformly on it, so
// the area density is pmf / area = luminance(Le) / total power (the material's light_pdf_area,
// which emitted_radiance uses for MIS; with emission textures the triangle's own pmf / area,
// glsl/emission_texture.glsl, as the pick is by each triangle's textured power).

// Uniform point on a triangle (square-root parametrisation, pbrt-v4 SampleUniformTriangle).
vec2 sample_triangle_bary(vec2 u) {
    float su = sqrt(u.x);
    return vec2(u.y * su, 1.0 - su);  // (b1, b2) for v1, v2
}

// A point on triangle tri (picked with probability pmf) seen from xo; pdf 0 when it faces away.
void area_sample(inout LightSample ls, int tri, float pmf, vec3 xo, vec2 u) {
    ls.tri = tri;
    vec2 bary = sample_triangle_bary(u);
    ls.y = tri_point(tri, bary);
#if MCPT_EMISSION_TEXTURES
    ls.bary = bary;  // where light_radiance reads the emission texture
#endif
    vec3 nl = tri_normal_raw(tri);
    float area2 = length(nl);  // twice the area
    nl /= area2;
    ls.n = nl;
    vec3 dv = ls.y - xo;
    float d2 = dot(dv, dv);
    ls.dist = sqrt(d2);
    ls.wi = dv / ls.dist;
    float cos_l = -dot(nl, ls.wi);  // > 0: y faces xo
    // Solid-angle density: pmf / area, turned by d^2 / cos_l.
    ls.pdf = cos_l > 0.0 ? pmf * (2.0 / area2) * d2 / cos_l : 0.0;
}
