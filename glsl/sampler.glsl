// Random numbers of a path. The layout is defined once on the host (mcpt/shading/sampler.py) and arrives
// here as defines: dims 0-1 camera jitter; bounce k (1-based) owns DIM_BOUNCE(k) + 0..5.
#define DIM_CAMERA 0
#define DIM_BOUNCE(k) (MCPT_DIMS_CAMERA + MCPT_DIMS_PER_BOUNCE * ((k) - 1))
#define DIM_LIGHT_PICK MCPT_DIM_LIGHT_PICK
#define DIM_LIGHT_UV MCPT_DIM_LIGHT_UV
#define DIM_BSDF_UV MCPT_DIM_BSDF_UV
#define DIM_RR MCPT_DIM_RR
#define DIM_LENS DIM_BOUNCE(MCPT_BOUNCES + 1)  // thin lens: after the last bounce's share

#if MCPT_SAMPLER_SOBOL
#include "sobol.glsl"
// `pixel` over the whole image, so tiling never changes a pixel's numbers; sample j of the draw
// (path regeneration, glsl/pathtrace.frag) is sample u_sample_index + j of the pixel.
void sampler_init(int pixel, int tile_pixel, int j) { sobol_init(pixel, u_sample_index + uint(j)); }
float rand_at(int dim) { return sobol_1d(dim); }
vec2 rand2_at(int dim) { return sobol_2d(dim); }
#else
// Independent numbers uploaded every pass, dimension-major: number `dim` of pixel p of the
// current tile is at dim * u_rand_stride + p (u_rand_stride = the tile's pixel count).
// Neighbouring pixels, which llvmpipe and GPUs shade side by side in one SIMD batch, then read
// neighbouring addresses for the same dimension: one cache line instead of a gather over lines
// (measured: random texelFetch is ~12x slower than a coherent one on llvmpipe).
// Every pass uploads fresh numbers, so no two passes, pixels or bounces share a number.
layout(binding = 5) uniform samplerBuffer u_random;  // R32F, uniform in [0, 1)

uniform int u_rand_stride;
int g_rand_pixel;

// One sample per draw (j = 0): the numbers are uploaded per pass.
void sampler_init(int pixel, int tile_pixel, int j) { g_rand_pixel = tile_pixel; }

// numpy's float32 generator: k * 2^-24, never 1.0.
float rand_at(int dim) { return texelFetch(u_random, dim * u_rand_stride + g_rand_pixel).r; }

vec2 rand2_at(int dim) { return vec2(rand_at(dim), rand_at(dim + 1)); }
#endif

// The numbers of a bounce's BSDF sample: its direction pair, and a third only a rough dielectric
// reads (reflect or refract): + 0, which surface light sampling leaves unread (media's equiangular
// pick may share it; mcpt/shading/sampler.py says why that is unbiased). Others read nothing more.
vec3 rand_bsdf(int dim) {
#if MCPT_MAT_ROUGH_DIELECTRIC
    return vec3(rand2_at(dim + DIM_BSDF_UV), rand_at(dim + DIM_LIGHT_PICK));
#else
    return vec3(rand2_at(dim + DIM_BSDF_UV), 0.0);
#endif
}
