// Image textures (host side: mcpt/shading/texture.py documents the buffer; UVs: pack_uvs there).
// 8-bit texels stay sRGB-encoded, 8 bits a channel (float textures: linear float texels); each of the four taps of a bilinear lookup is
// decoded to linear RGB before the interpolation, as a GPU's sRGB texture does.
// A texture may carry a UV transform (Mitsuba's to_uv) and may be a procedural checkerboard
// (glsl/checkerboard.glsl); both are flags in its header, read per lookup.
// The buffers and lookups are compiled only with MCPT_TEXTURES; albedo_at always.
#include "geometry.glsl"
#include "materials.glsl"

#if MCPT_TEXTURES
layout(binding = 8) uniform usamplerBuffer u_uvs;       // 2 texels per triangle (BVH order)
layout(binding = 9) uniform usamplerBuffer u_textures;  // headers, then 4 pixels per texel
#include "checkerboard.glsl"

vec2 tri_uv(int tri, vec2 bary) {
#if MCPT_SPHERES
    if (hit_is_sphere(tri)) return sphere_uv(Hit(0.0, tri, bary));
#endif
    vec4 a = uintBitsToFloat(texelFetch(u_uvs, 2 * tri));
    vec2 c = uintBitsToFloat(texelFetch(u_uvs, 2 * tri + 1).xy);
    return (1.0 - bary.x - bary.y) * a.xy + bary.x * a.zw + bary.y * c;
}

// The exact sRGB decoding curve (IEC 61966-2-1).
vec3 srgb_decode(uint p) {
    vec3 c = vec3(uvec3(p, p >> 8, p >> 16) & 0xffu) * (1.0 / 255.0);
    vec3 lo = c * (1.0 / 12.92);
    vec3 hi = pow((c + 0.055) * (1.0 / 1.055), vec3(2.4));
    return mix(hi, lo, lessThanEqual(c, vec3(0.04045)));
}

// Integer texel coordinate under the wrap mode (0 repeat, 1 clamp, 2 mirror), for i in
// [-1, 2n]: the coordinate was folded into one period first (tex_reduce). No `%`: GLSL leaves
// it undefined for negative operands.
int tex_wrap(int i, int n, uint mode) {
    if (mode == 1u) return clamp(i, 0, n - 1);
    if (mode == 2u) {
        int p = i < 0 ? i + 2 * n : (i >= 2 * n ? i - 2 * n : i);
        return p < n ? p : 2 * n - 1 - p;
    }
    return i < 0 ? i + n : (i >= n ? i - n : i);
}

// A texture coordinate folded into one period first, so huge UVs keep their precision in the
// fraction and the integer texel index cannot overflow.
float tex_reduce(float u, uint mode) {
    if (mode == 1u) return clamp(u, 0.0, 1.0);
    if (mode == 2u) return u - 2.0 * floor(0.5 * u);
    return u - floor(u);
}

vec3 tex_pixel(uvec4 hdr, int x, int y) {
    int i = y * int(hdr.y) + x;
#if MCPT_FLOAT_TEXTURES
    // Issue #22: a float texture (EXR, HDR, 16-bit), one RGBA32F texel per pixel, linear values.
    // Compiled only for a scene that has one, so 8-bit scenes run the code they ran before.
    if ((hdr.w & 64u) != 0u) return uintBitsToFloat(texelFetch(u_textures, int(hdr.x) + i).xyz);
#endif
    uint p = texelFetch(u_textures, int(hdr.x) + (i >> 2))[i & 3];
    if ((hdr.w & 32u) != 0u) return vec3(uvec3(p, p >> 8, p >> 16) & 0xffu) * (1.0 / 255.0);  // linear
    return srgb_decode(p);
}

// Linear RGB of texture `id` at (u, v); v points up (row 0 of the buffer is the image's bottom).
vec3 texture_rgb(int id, vec2 uv) {
    uvec4 hdr = texelFetch(u_textures, id);
    if ((hdr.w & 8u) != 0u) {  // a UV transform leads the data: (a, b, c, d), (e, f, 0, 0)
        vec4 p = uintBitsToFloat(texelFetch(u_textures, int(hdr.x)));
        vec2 q = uintBitsToFloat(texelFetch(u_textures, int(hdr.x) + 1).xy);
        uv = vec2(p.x * uv.x + p.y * uv.y + p.z, p.w * uv.x + q.x * uv.y + q.y);
        hdr.x += 2u;
    }
    if ((hdr.w & 16u) != 0u) return checkerboard_rgb(int(hdr.x), uv);
    int w = int(hdr.y), h = int(hdr.z);
    uint mode = hdr.w & 3u;
    vec2 st = vec2(tex_reduce(uv.x, mode), tex_reduce(uv.y, mode)) * vec2(w, h);
    if ((hdr.w & 4u) != 0u) {  // nearest
        return tex_pixel(hdr, tex_wrap(int(floor(st.x)), w, mode), tex_wrap(int(floor(st.y)), h, mode));
    }
    st -= 0.5;
    vec2 f = floor(st);
    vec2 t = st - f;
    int x0 = int(f.x), y0 = int(f.y);
    int xa = tex_wrap(x0, w, mode), xb = tex_wrap(x0 + 1, w, mode);
    int ya = tex_wrap(y0, h, mode), yb = tex_wrap(y0 + 1, h, mode);
    vec3 bot = mix(tex_pixel(hdr, xa, ya), tex_pixel(hdr, xb, ya), t.x);
    vec3 top = mix(tex_pixel(hdr, xa, yb), tex_pixel(hdr, xb, yb), t.x);
    return mix(bot, top, t.y);
}
#endif

// The albedo at hit h: the material's texture there if it has one, else its constant albedo.
vec3 albedo_at(Material m, Hit h) {
    vec3 albedo = m.albedo;
#if MCPT_TEXTURES
    if (m.texture >= 0) albedo = texture_rgb(m.texture, tri_uv(h.tri, h.bary));
#if MCPT_MAT_METALROUGH
    // glTF's base colour: the texture times baseColorFactor (the row's albedo, 1 without one).
    if (m.texture >= 0 && m.type == MAT_METALROUGH) albedo *= m.albedo;
#endif
#endif
    return albedo;
}

#if MCPT_MAT_METALROUGH
// A metal-rough material's metallicRoughnessTexture at hit h (mcpt/shading/metalrough.py), read
// linearly: metallic (m.scale.x) times its blue, the perceptual roughness factor (m.scale.z) times
// its green, alpha = roughness^2 floored as the host floors it. Texture id in m.scale.y (-1: none).
void metalrough_at(inout Material m, Hit h) {
#if MCPT_TEXTURES
    if (m.type != MAT_METALROUGH || m.scale.y < 0.0) return;
    vec3 c = texture_rgb(int(m.scale.y), tri_uv(h.tri, h.bary));
    float r = m.scale.z * c.g;
    m.scale.x *= c.b;
    m.alpha = max(r * r, 1e-3);
#endif
}
#endif
