// Pre-generated random numbers (host side: mcpt/shading/sampler.py, which documents the layout).
// Dimension-major: number `dim` of pixel p of the current tile is at dim * u_rand_stride + p
// (u_rand_stride = the tile's pixel count). Neighbouring pixels, which llvmpipe and GPUs shade
// side by side in one SIMD batch, then read neighbouring addresses for the same dimension: one
// cache line instead of a gather over lines (measured: random texelFetch is ~12x slower than a
// coherent one on llvmpipe). dims 0-1 camera jitter; bounce k (1-based) owns DIM_BOUNCE(k) + 0..5.
// Every pass uploads fresh numbers, so no two passes, pixels or bounces share a number.
layout(binding = 5) uniform samplerBuffer u_random;  // R32F, uniform in [0, 1)

#define DIM_CAMERA 0
#define DIM_BOUNCE(k) (2 + 6 * ((k) - 1))
#define DIM_LIGHT_PICK 0
#define DIM_LIGHT_UV 1
#define DIM_BSDF_UV 3
#define DIM_RR 5

uniform int u_rand_stride;
int g_rand_pixel;

void sampler_init(int pixel) { g_rand_pixel = pixel; }

// numpy's float32 generator: k * 2^-24, never 1.0.
float rand_at(int dim) { return texelFetch(u_random, dim * u_rand_stride + g_rand_pixel).r; }

vec2 rand2_at(int dim) { return vec2(rand_at(dim), rand_at(dim + 1)); }
