// Environment map (Mitsuba's "envmap" emitter): radiance arriving from infinitely far away, from a
// latitude-longitude image, importance-sampled for next-event estimation. Host side, with the
// derivations and the buffer layout: mcpt/shading/envmap.py. Included by glsl/lights.glsl when the
// scene has an environment map (its feature define). The contract:
//   vec3  env_radiance(vec3 d)                   radiance a ray escaping along unit world d sees
//   vec3  env_sample(vec2 u, out float pdf)      unit world direction, pdf per steradian
//   float env_pdf(vec3 d)                        the pdf env_sample has at d (the same function)
//   vec3  env_radiance_pdf(vec3 d, out float pdf)           both at once (4 texel fetches)
//   vec3  env_sample_le(vec2 u, out float pdf, out vec3 le) sample + its radiance at once
//
// Mapping, exactly Mitsuba 3's (src/emitters/envmap.cpp v3.9.1: uv_to_direction l. 439-446,
// direction_to_uv l. 449-452, bilinear eval_spectrum l. 533-540), in the emitter's frame:
//   d = (sin(2 pi u) sin(pi v), cos(pi v), -cos(2 pi u) sin(pi v)):
// v = 0 is +Y (the image's top row), u = 0 looks along -Z, u = 1/4 along +X. Column x is centred
// on u = (x + 1/2) / W (periodic), row y lies on v = y / (H - 1) (top and bottom rows on the
// poles); the radiance is bilinear between them.
//
// Sampling: pbrt-v4 sec. A.5 "Piecewise-constant 2D distributions" over the W x (H - 1) cells
// between four texels: a marginal distribution picks the row of cells, that row's conditional one
// the cell, each from an alias table (Walker / Vose, pbrt-v4 sec. A.1; mcpt/shading/alias.py):
// one texel read each and no loop, where binary searches over CDFs cost log2(H) + log2(W)
// dependent reads and loop trips under llvmpipe's 8-lane masks. Cell probabilities are
// proportional to the luminance integrated over the cell's solid angle (luminance x sin theta,
// integrated exactly on the host). Inside the cell the direction is bilinear in (phi, cos theta)
// with the corners' luminances (env_bilinear_pdf; uniform in a black cell); as (phi, cos theta)
// is uniform in solid angle, the solid-angle pdf is the cell's mean, stored beside the texel,
// times the bilinear factor: no 1 / sin theta (pbrt-v4 sec. 12.5's pdf_uv / (2 pi^2 sin theta)),
// finite and consistent at the poles.
#include "common.glsl"

// W x H texels (R, G, B, pdf of the cell whose top-left corner this texel is) as float bits,
// the image row by row from its top row (v = 0, +Y). The last row starts no cell (pdf 0).
layout(binding = 10) uniform usamplerBuffer u_env_texels;
// Alias-table entries (threshold bits, alias index), 2 per texel: [0, H') the table over the rows
// of cells, then at H' + j W' + i entry i of row j's table; H', W' = env_pow2(H - 1), env_pow2(W).
layout(binding = 11) uniform usamplerBuffer u_env_alias;
uniform ivec2 u_env_size;     // (W, H) texels, W >= 2, H >= 3
uniform mat3 u_env_to_world;  // emitter-to-world rotation or mirror: its transpose is its inverse

// The power of two >= n (n >= 1): an alias table's bucket count (alias.py padded_size).
int env_pow2(int n) { return 1 << (findMSB(n - 1) + 1); }

// The item that u picks from the n-bucket alias table at entry base (n a power of two, so u n
// and its fraction f are exact): bucket b = floor(u n) itself if f < q_b, else its alias; t is
// f remapped to [0, 1) within the choice, reused to place the point in the item.
int env_alias_pick(int base, int n, float u, out float t) {
    float x = u * float(n);
    int b = min(int(x), n - 1);
    float f = x - float(b);
    int e = base + b;
    uvec4 tx = texelFetch(u_env_alias, e >> 1);
    uvec2 qa = (e & 1) == 0 ? tx.xy : tx.zw;
    float q = uintBitsToFloat(qa.x);
    bool own = f < q;
    t = clamp(own ? f / q : (f - q) / (1.0 - q), 0.0, 1.0);
    return own ? b : int(qa.y);
}

// (cos theta_j - cos theta) / (cos theta_j - cos theta_(j+1)) for theta at fraction fy of row j's
// band [j, j + 1] pi / hc, by cos a - cos b = 2 sin((a + b) / 2) sin((b - a) / 2): no cancellation
// near the poles, where cos theta is within a few ulps of +-1.
float env_cos_fraction(int j, int hc, float fy) {
    float dt = PI / float(hc), tj = float(j) * dt;
    return sin(tj + 0.5 * fy * dt) * sin(0.5 * fy * dt) / (sin(tj + 0.5 * dt) * sin(0.5 * dt));
}

// Texel index of the top-left corner of world direction d's cell; dx = offset to the corner on its
// right (1, or 1 - W across the seam u = 0); f = bilinear weights (x in phi, y in theta) and
// fz = the fraction in cos theta across the cell's band (env_cos_fraction). The same steps as the
// numpy reference EnvMap._cells.
int env_cell(vec3 d, out int dx, out vec2 f, out float fz) {
    int W = u_env_size.x, H = u_env_size.y;
    vec3 l = d * u_env_to_world;  // to_world^T d
    float r = sqrt(l.x * l.x + l.z * l.z);
    float phi = r > 0.0 ? atan(l.x, -l.z) : 0.0;  // atan(0, 0) is undefined at the poles
    float theta = atan(r, l.y);                    // accurate near the poles, unlike acos(l.y)
    float x = phi * (float(W) * (0.5 * INV_PI)) - 0.5;  // u W - 1/2
    if (x < 0.0) x += float(W);
    float fx = floor(x);
    int i = int(fx);
    f.x = x - fx;
    if (i >= W) i -= W;
    float y = theta * (float(H - 1) * INV_PI);     // v (H - 1)
    int j = min(int(y), H - 2);
    f.y = y - float(j);
    fz = env_cos_fraction(j, H - 1, f.y);
    dx = i + 1 >= W ? 1 - W : 1;
    return j * W + i;
}

// Within a cell the sampler is bilinear in (fx, fz) (fz in cos theta, the variable uniform in
// solid angle) with the corners' luminances: pbrt-v4's SampleBilinear (its SampleLinear twice),
// the counterpart of Mitsuba's bilinear Hierarchical2D over (u, v) with corners lum x sin theta.
// The radiance is bilinear in theta rather than cos theta, a small difference in a band of
// pi / (H - 1): sun-like cells, whose corners differ by orders of magnitude, are sampled in
// proportion to their radiance instead of uniformly (the per-cell constant density had 2-6x the
// variance of the direct light on a diffuse surface under bench/scenes-xml/sky-sun.exr; issue
// #20). The corners are divided by the largest, so no square below overflows.
vec4 env_unit_max(vec4 v) {
    float m = max(max(v.x, v.y), max(v.z, v.w));
    return m > 0.0 ? v / m : v;
}

vec4 env_corner_lum(int k, int dx, int W) {
    return env_unit_max(vec4(luminance(uintBitsToFloat(texelFetch(u_env_texels, k).rgb)),
                             luminance(uintBitsToFloat(texelFetch(u_env_texels, k + dx).rgb)),
                             luminance(uintBitsToFloat(texelFetch(u_env_texels, k + W).rgb)),
                             luminance(uintBitsToFloat(texelFetch(u_env_texels, k + W + dx).rgb))));
}

// The density at f = (fx, fz) of the bilinear warp with corners v (v00, v10, v01, v11), relative
// to uniform: B(f) / mean(v); 1 for a black cell (then sampled uniformly).
float env_bilinear_pdf(vec2 f, vec4 v) {
    float s = v.x + v.y + v.z + v.w;
    return s > 0.0 ? 4.0 * mix(mix(v.x, v.y, f.x), mix(v.z, v.w, f.x), f.y) / s : 1.0;
}

vec3 env_radiance_pdf(vec3 d, out float pdf) {
    int dx;
    vec2 f;
    float fz;
    int k = env_cell(d, dx, f, fz);
    int W = u_env_size.x;
    vec4 t00 = uintBitsToFloat(texelFetch(u_env_texels, k));
    vec3 t10 = uintBitsToFloat(texelFetch(u_env_texels, k + dx).rgb);
    vec3 t01 = uintBitsToFloat(texelFetch(u_env_texels, k + W).rgb);
    vec3 t11 = uintBitsToFloat(texelFetch(u_env_texels, k + W + dx).rgb);
    vec4 v = env_unit_max(vec4(luminance(t00.rgb), luminance(t10), luminance(t01), luminance(t11)));
    pdf = t00.w * env_bilinear_pdf(vec2(f.x, fz), v);
    return mix(mix(t00.rgb, t10, f.x), mix(t01, t11, f.x), f.y);
}

vec3 env_radiance(vec3 d) {
    float pdf;
    return env_radiance_pdf(d, pdf);
}

float env_pdf(vec3 d) {
    float pdf;
    env_radiance_pdf(d, pdf);
    return pdf;
}

// (cos theta, sin theta) at fraction t of row j's band [pi j, pi (j + 1)] / hc, uniform in
// cos theta, through s = 1 - cos theta = 2 sin^2(theta / 2) in the northern half and
// s = 1 + cos theta = 2 cos^2(theta / 2) in the southern: sin theta = sqrt(s (2 - s)) stays
// accurate next to the pole, where cos theta is within a few ulps of +-1.
vec2 env_band_point(int j, int hc, float t) {
    bool north = 2 * j + 1 < hc;
    float h0 = (0.5 * PI) * float(j) / float(hc), h1 = (0.5 * PI) * float(j + 1) / float(hc);
    float a0 = north ? sin(h0) : cos(h0), a1 = north ? sin(h1) : cos(h1);
    float s = mix(2.0 * a0 * a0, 2.0 * a1 * a1, t);
    return vec2(north ? 1.0 - s : s - 1.0, sqrt(max(s * (2.0 - s), 0.0)));
}

// pbrt-v4 SampleLinear: x in [0, 1) with density proportional to mix(a, b, x), a, b >= 0 (in
// [0, 1] here: env_corner_lum); a == b (a black cell too) is uniform.
float env_sample_linear(float u, float a, float b) {
    if (a == b) return u;
    float den = a + sqrt(mix(a * a, b * b, u));
    return den > 0.0 ? min(u * (a + b) / den, 0.99999994) : 0.0;
}

// u.y picks the row of cells, u.x the cell in it. The pdf and radiance are looked up from the
// direction (env_radiance_pdf), so pdf == env_pdf(d) exactly; it can differ from the sampled
// cell's only for a direction on a cell border (float rounding), a set of measure zero.
vec3 env_sample_le(vec2 u, out float pdf, out vec3 le) {
    int W = u_env_size.x, hc = u_env_size.y - 1;
    int hp = env_pow2(hc), wp = env_pow2(W);
    float tv, tu;
    int j = env_alias_pick(0, hp, u.y, tv);
    int i = env_alias_pick(hp + j * wp, wp, u.x, tu);
    // pbrt-v4 SampleBilinear: fz from the marginal in z, then fx given fz (SampleLinear each).
    vec4 v = env_corner_lum(j * W + i, i + 1 >= W ? 1 - W : 1, W);
    float fz = env_sample_linear(tv, v.x + v.y, v.z + v.w);
    float fx = env_sample_linear(tu, mix(v.x, v.z, fz), mix(v.y, v.w, fz));
    float phi = (float(i) + 0.5 + fx) * (2.0 * PI / float(W));
    vec2 cs = env_band_point(j, hc, fz);
    vec3 d = u_env_to_world * vec3(sin(phi) * cs.y, cs.x, -cos(phi) * cs.y);
    le = env_radiance_pdf(d, pdf);
    return d;
}

vec3 env_sample(vec2 u, out float pdf) {
    vec3 le;
    return env_sample_le(u, pdf, le);
}
