// Pre-generated random numbers (host side: mcpt/sampler.py, which documents the layout).
// Pixel p of the current tile reads the MCPT_RAND_DIMS uints starting at p * MCPT_RAND_DIMS:
// dims 0-1 camera jitter; bounce k (1-based) owns dims DIM_BOUNCE(k) + 0..5 (see below).
// Every pass uploads fresh numbers, so no two passes, pixels or bounces share a number.
layout(binding = 5) uniform samplerBuffer u_random;  // R32F, uniform in [0, 1)

#define DIM_CAMERA 0
#define DIM_BOUNCE(k) (2 + 6 * ((k) - 1))
#define DIM_LIGHT_PICK 0
#define DIM_LIGHT_UV 1
#define DIM_BSDF_UV 3
#define DIM_RR 5

int g_rand_base;

void sampler_init(int pixel) { g_rand_base = pixel * MCPT_RAND_DIMS; }

// numpy's float32 generator: k * 2^-24, never 1.0.
float rand_at(int dim) { return texelFetch(u_random, g_rand_base + dim).r; }

vec2 rand2_at(int dim) { return vec2(rand_at(dim), rand_at(dim + 1)); }
