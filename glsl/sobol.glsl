// Padded, Owen-scrambled Sobol' numbers (--sampler sobol), and one joint 6-D point for the path
// dims MCPT_SOBOL_JOINT0..2. mcpt/shading/sobol.py is the numpy twin, bit for bit, and explains the
// construction (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4); pbrt-v4
// PaddedSobolSampler). Nothing is uploaded: the seeds are hashes of
// (--seed, pixel, dimension), the sample index is the pass.
uniform uint u_sobol_seed;    // 32-bit key derived from --seed (mcpt/shading/sobol.py seed32)
uniform uint u_sample_index;  // the pass

#ifndef MCPT_SOBOL_JOINT
#define MCPT_SOBOL_JOINT 0
#endif

uint g_sobol_pixel;  // per-pixel key
uint g_sobol_index;  // the sample index (u_sample_index in the renderer)
// The sample's joint point: the 2D samples of path dims MCPT_SOBOL_JOINT0..2 (sobol_init).
vec2 g_sobol_joint0, g_sobol_joint1, g_sobol_joint2;

// Sobol' dimensions 2-5 of a 16-bit index, bit-reversed: the XOR of the generator matrix's
// columns of the index's set bits. The columns (Joe & Kuo 2008; mcpt/shading/sobol.py
// JOINT_COLUMNS computes them, the tests compare the two bit for bit) fit in 16 bits, so two
// dimensions share each word: dimension 2 | 3 << 16 in d23, 4 | 5 << 16 in d45. Written out:
// llvmpipe indexes a constant array in a loop with a compare-and-select ladder.
void sobol_dims_2_5(uint i, out uint d23, out uint d45) {
    uint m;
    d23 = 0u; d45 = 0u;
    m = 0u - ((i >> 0u) & 1u); d23 ^= m & 0x00010001u; d45 ^= m & 0x00010001u;
    m = 0u - ((i >> 1u) & 1u); d23 ^= m & 0x00030003u; d45 ^= m & 0x00020002u;
    m = 0u - ((i >> 2u) & 1u); d23 ^= m & 0x00040006u; d45 ^= m & 0x00060004u;
    m = 0u - ((i >> 3u) & 1u); d23 ^= m & 0x000a0009u; d45 ^= m & 0x000c000du;
    m = 0u - ((i >> 4u) & 1u); d23 ^= m & 0x001f0017u; d45 ^= m & 0x0013001fu;
    m = 0u - ((i >> 5u) & 1u); d23 ^= m & 0x002e003au; d45 ^= m & 0x0024003bu;
    m = 0u - ((i >> 6u) & 1u); d23 ^= m & 0x00450071u; d45 ^= m & 0x006a005eu;
    m = 0u - ((i >> 7u) & 1u); d23 ^= m & 0x00c900a3u; d45 ^= m & 0x00df00b9u;
    m = 0u - ((i >> 8u) & 1u); d23 ^= m & 0x011b0116u; d45 ^= m & 0x0107015au;
    m = 0u - ((i >> 9u) & 1u); d23 ^= m & 0x02a40339u; d45 ^= m & 0x020e03f4u;
    m = 0u - ((i >> 10u) & 1u); d23 ^= m & 0x079a0677u; d45 ^= m & 0x06150685u;
    m = 0u - ((i >> 11u) & 1u); d23 ^= m & 0x0b6709aau; d45 ^= m & 0x0c280d0fu;
    m = 0u - ((i >> 12u) & 1u); d23 ^= m & 0x101e1601u; d45 ^= m & 0x1379115bu;
    m = 0u - ((i >> 13u) & 1u); d23 ^= m & 0x302d3903u; d45 ^= m & 0x24fb23f6u;
    m = 0u - ((i >> 14u) & 1u); d23 ^= m & 0x40417706u; d45 ^= m & 0x6b6d4681u;
    m = 0u - ((i >> 15u) & 1u); d23 ^= m & 0xa0c3aa09u; d45 ^= m & 0xddd1dd02u;
}

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

float sobol_joint(uint v, uint epoch, uint t) {
    return sobol_float(bitfieldReverse(laine_karras(v, sobol_hash(epoch + t + 1u))));
}

void sobol_init(int pixel, uint index) {
    g_sobol_pixel = sobol_hash(u_sobol_seed ^ sobol_hash(uint(pixel)));
    g_sobol_index = index;
    // The joint point (mcpt/shading/sobol.py joint_bits): one shuffle of the index for all six
    // coordinates, 16 of its bits; the bits above seed the scrambles.
#if MCPT_SOBOL_JOINT
    uint key = sobol_hash(g_sobol_pixel ^ 0x6a09e667u);
    uint low = bitfieldReverse(laine_karras(bitfieldReverse(index), key)) & 0xffffu;
    uint epoch = sobol_hash(key ^ (index >> 16));
    g_sobol_joint0 = vec2(sobol_joint(low, epoch, 0u), sobol_joint(sobol_pascal(low), epoch, 1u));
    uint d23, d45;
    sobol_dims_2_5(low, d23, d45);
    g_sobol_joint1 = vec2(sobol_joint(d23 & 0xffffu, epoch, 2u), sobol_joint(d23 >> 16, epoch, 3u));
    g_sobol_joint2 = vec2(sobol_joint(d45 & 0xffffu, epoch, 4u), sobol_joint(d45 >> 16, epoch, 5u));
#endif
}

// Index shuffle of dimension `dim`; also returns the dimension's key.
uint sobol_index(int dim, out uint s) {
    s = sobol_hash(g_sobol_pixel ^ sobol_hash(uint(dim)));
    return bitfieldReverse(laine_karras(bitfieldReverse(g_sobol_index), s));
}

// The joint point's pair where `dim` is one of its dims, else `padded`. Compiled out where paths
// have one bounce (features: MCPT_SOBOL_JOINT, mcpt/shading/sampler.py joint_used).
vec2 sobol_joined(int dim, vec2 padded) {
#if MCPT_SOBOL_JOINT
    padded = dim == MCPT_SOBOL_JOINT0 ? g_sobol_joint0 : padded;
    padded = dim == MCPT_SOBOL_JOINT1 ? g_sobol_joint1 : padded;
    padded = dim == MCPT_SOBOL_JOINT2 ? g_sobol_joint2 : padded;
#endif
    return padded;
}

float sobol_1d(int dim) {
    uint s;
    uint i = sobol_index(dim, s);
    return sobol_joined(dim, vec2(sobol_float(bitfieldReverse(laine_karras(i, sobol_hash(s + 1u)))))).x;
}

vec2 sobol_2d(int dim) {
    uint s;
    uint i = sobol_index(dim, s);
    return sobol_joined(dim, vec2(sobol_float(bitfieldReverse(laine_karras(i, sobol_hash(s + 1u)))),
                                  sobol_float(bitfieldReverse(laine_karras(sobol_pascal(i), sobol_hash(s + 2u))))));
}
