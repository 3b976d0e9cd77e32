// Emission textures (issue #22; host side: mcpt/shading/emission_texture.py): an emitter's radiance
// is its texture at the hit's UV times the material's emission (a scale), and next-event estimation
// picks each emissive triangle by its actual power (the texture's luminance integrated over it), so
// the area density of a light sample is per TRIANGLE: pmf / area, read from u_emit_pdf by BSDF-hit
// emission for MIS (glsl/lights.glsl), the same value light sampling uses. Compiled only with
// MCPT_EMISSION_TEXTURES (which implies MCPT_TEXTURES: the UV and texel buffers).
#include "texture.glsl"

// Emitted radiance of material m at barycentrics bary of triangle tri (front side).
vec3 emission_at(Material m, int tri, vec2 bary) {
    vec3 le = m.emission;
    if (m.emission_texture >= 0) le *= texture_rgb(m.emission_texture, tri_uv(tri, bary));
    return le;
}

#if MCPT_NEE
// Per triangle (BVH order), 4 a texel: pmf / area of its light entry (0: not an emitter).
layout(binding = 14) uniform usamplerBuffer u_emit_pdf;

float emitter_pdf_area(int tri) {
    return uintBitsToFloat(texelFetch(u_emit_pdf, tri >> 2)[tri & 3]);
}
#else
float emitter_pdf_area(int tri) { return 0.0; }  // unused: without NEE, emission has weight 1
#endif
