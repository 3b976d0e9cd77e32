// Roughness textures (issue #22; host side: mcpt/shading/roughness_texture.py): a rough conductor's
// or rough dielectric's alpha at hit h is its table alpha (the roughness factor, texel 2.x) times
// the texture's first channel there, floored at the least alpha either material takes
// (materials.MIN_ALPHA = 0.001) and at most 1. The texture id + 1 is in flags bits 16-31 (0: none).
// Called once per hit where the material is fetched (glsl/pathtrace.frag), so light sampling, BSDF
// sampling and evaluation, and both MIS densities at the hit see one alpha.
#include "texture.glsl"

void roughness_at(inout Material m, Hit h) {
    int id = int(m.flags >> 16u) - 1;
    if (id < 0) return;
    float r = texture_rgb(id, tri_uv(h.tri, h.bary)).r;
    m.alpha = clamp(m.alpha * r, 0.001, 1.0);
}
