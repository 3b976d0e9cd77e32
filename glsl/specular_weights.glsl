// Specular weights (issue #22; host side mcpt/shading/specular_weights.py): Mitsuba 3's
// specular_reflectance / specular_transmittance, a constant in the material table or an image
// there (sRGB-decoded, as Mitsuba's bitmap with raw=false) that replaces it at the hit.
#if MCPT_SPECULAR_WEIGHTS
void specular_weights_at(inout Material m, Hit h) {
#if MCPT_TEXTURES
    if (m.spec_r_tex >= 0) m.spec_r = texture_rgb(m.spec_r_tex, tri_uv(h.tri, h.bary));
    if (m.spec_t_tex >= 0) m.spec_t = texture_rgb(m.spec_t_tex, tri_uv(h.tri, h.bary));
#endif
}
#endif
