// Padded, Owen-scrambled Sobol' numbers (--sampler sobol). mcpt/shading/sobol.py is the numpy twin, bit
// for bit, and explains the construction (Burley 2020, "Practical Hash-based Owen Scrambling",
// JCGT 9(4); pbrt-v4 PaddedSobolSampler). Nothing is uploaded: the seeds are hashes of
// (--seed, pixel, dimension), the sample index is the pass.
uniform uint u_sobol_seed;    // 32-bit key derived from --seed (mcpt/shading/sobol.py seed32)
uniform uint u_sample_index;  // the pass

uint g_sobol_pixel;  // per-pixel key
uint g_sobol_index;  // the sample index (u_sample_index in the renderer)

// C. Wellons' "lowbias32" integer hash.
uint sobol_hash(uint x) {
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}

// Each bit depends only on itself and lower bits; applied to reversed bits it is a nested uniform
// (Owen) scramble. N. Vegdahl's improved Laine-Karras hash (2021), as pbrt-v4's
// FastOwenScrambler: Burley 2020's listing 2 left samples correlated (mcpt/shading/sobol.py).
uint laine_karras(uint x, uint seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

// Sobol' dimension 1, bit-reversed: Pascal's triangle mod 2 as a superset transform.
uint sobol_pascal(uint u) {
    u ^= (u >> 1) & 0x55555555u; u ^= (u >> 2) & 0x33333333u; u ^= (u >> 4) & 0x0f0f0f0fu;
    u ^= (u >> 8) & 0x00ff00ffu; u ^= (u >> 16) & 0x0000ffffu;
    return u;
}

float sobol_float(uint v) { return float(v >> 8) * (1.0 / 16777216.0); }

void sobol_init(int pixel, uint index) {
    g_sobol_pixel = sobol_hash(u_sobol_seed ^ sobol_hash(uint(pixel)));
    g_sobol_index = index;
}

// Index shuffle of dimension `dim`; also returns the dimension's key.
uint sobol_index(int dim, out uint s) {
    s = sobol_hash(g_sobol_pixel ^ sobol_hash(uint(dim)));
    return bitfieldReverse(laine_karras(bitfieldReverse(g_sobol_index), s));
}

float sobol_1d(int dim) {
    uint s;
    uint i = sobol_index(dim, s);
    return sobol_float(bitfieldReverse(laine_karras(i, sobol_hash(s + 1u))));
}

vec2 sobol_2d(int dim) {
    uint s;
    uint i = sobol_index(dim, s);
    return vec2(sobol_float(bitfieldReverse(laine_karras(i, sobol_hash(s + 1u)))),
                sobol_float(bitfieldReverse(laine_karras(sobol_pascal(i), sobol_hash(s + 2u)))));
}
