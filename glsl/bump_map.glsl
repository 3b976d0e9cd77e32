// Bump maps (host side: mcpt/shading/bump_map.py, which documents the convention and holds the
// numpy reference): a height texture's analytic bilinear gradient perturbs the triangle's dp/du
// and dp/dv, Mitsuba 3's bumpmap (src/bsdfs/bumpmap.cpp). Compiled only with MCPT_NORMAL_MAPS.
#include "geometry.glsl"
#include "texture.glsl"

#if MCPT_NORMAL_MAPS
// The height of a texel: its luminance (Rec. 709 weights, Mitsuba's eval_1 of an RGB bitmap).
float tex_height(uvec4 hdr, int x, int y) { return dot(tex_pixel(hdr, x, y), vec3(0.2126, 0.7152, 0.0722)); }

// d height / d(u, v) of texture `id`'s bilinear interpolant at uv (per unit of u and v: the
// texel differences times the resolution). Mitsuba's bitmap eval_1_grad.
vec2 texture_grad(int id, vec2 uv) {
    uvec4 hdr = texelFetch(u_textures, id);
    int w = int(hdr.y), h = int(hdr.z);
    uint mode = hdr.w & 3u;
    vec2 st = vec2(tex_reduce(uv.x, mode), tex_reduce(uv.y, mode)) * vec2(w, h) - 0.5;
    vec2 f = floor(st);
    vec2 t = st - f;
    int x0 = int(f.x), y0 = int(f.y);
    int xa = tex_wrap(x0, w, mode), xb = tex_wrap(x0 + 1, w, mode);
    int ya = tex_wrap(y0, h, mode), yb = tex_wrap(y0 + 1, h, mode);
    float a = tex_height(hdr, xa, ya), b = tex_height(hdr, xb, ya);
    float c = tex_height(hdr, xa, yb), d = tex_height(hdr, xb, yb);
    return vec2(mix(b - a, d - c, t.y) * float(w), mix(c - a, d - b, t.x) * float(h));
}

// The front side's bumped normal at hit h (height texture `tex` times `scale`, in world units per
// unit height) on a surface of front-side shading normal nf: dp/du' = dp/du + nf (scale dh/du -
// nf . dp/du), likewise v, n = dp/du' x dp/dv' turned to nf's side. dp/du, dp/dv: the triangle's
// own (from its corners and UVs), as Mitsuba's meshes have them; mcpt's v points the other way
// from Mitsuba's, which flips both dp/dv and dh/dv, and so neither the cross product's line nor,
// after the turn to nf's side, its sign.
vec3 bump_normal(int tex, float scale, Hit h, vec3 nf) {
    vec4 a = uintBitsToFloat(texelFetch(u_uvs, 2 * h.tri));
    vec2 uv2 = uintBitsToFloat(texelFetch(u_uvs, 2 * h.tri + 1).xy);
    vec3 p0 = tri_vertex(h.tri, 0);
    vec3 e1 = tri_vertex(h.tri, 1) - p0, e2 = tri_vertex(h.tri, 2) - p0;
    vec2 d1 = a.zw - a.xy, d2 = uv2 - a.xy;
    float det = d1.x * d2.y - d2.x * d1.y;
    if (abs(det) < 1e-20) return nf;  // degenerate UVs: no gradient to follow
    vec3 dpdu = (e1 * d2.y - e2 * d1.y) / det;
    vec3 dpdv = (e2 * d1.x - e1 * d2.x) / det;
    vec2 g = scale * texture_grad(tex, tri_uv(h.tri, h.bary));
    vec3 du = dpdu + nf * (g.x - dot(nf, dpdu));
    vec3 dv = dpdv + nf * (g.y - dot(nf, dpdv));
    vec3 n = cross(du, dv);
    float len = length(n);
    if (!(len > 0.0)) return nf;
    n /= len;
    return dot(n, nf) < 0.0 ? -n : n;
}
#endif
