// The wavefront dispatch (issue #23, the dispatch named `wavefront`; host side: mcpt/gpu/wavefront.py):
// the path tracer of glsl/pathtrace.frag cut at its closest-hit query into two compute kernels
// over the pixels ("slots") of a rectangle, u_dispatch (x0, y0 in GL rows from the bottom, width,
// height), run in turn until no path is left (Laine, Karras & Aila 2013, "Megakernels considered
// harmful: wavefront path tracing on GPUs"):
//   WAVE_KERNEL 0, shade: a slot's hit -> path_hit (emission, NEE with its shadow ray, the BSDF
//     sample, roulette); an ended sample is tallied and the slot's next one starts; the next ray
//     is queued. With u_wave_start the slots' first camera rays are made and queued.
//   WAVE_KERNEL 1, trace: the closest hit of each queued ray.
// Between them a path's state waits in images 0-3 (at its pixel), its hit and its tally in
// storage buffers. Rays are queued in two classes, those that enter the box of the BVH root's
// first child (the dense mesh, when the large triangles are written out: bvh.py large_tail) and
// the rest, so that a SIMD batch of the trace kernel holds rays of like length (bench/ray_order.py:
// 0.62x the traversal time of pixel order on the 100k sphere). A ray's hit does not depend on
// which invocation traces it, and each slot adds its samples in order: the same float32 adds as
// the fragment path's main(), so the same pixels (tests/test_dispatch.py).
layout(local_size_x = 64) in;
#ifndef WAVE_KERNEL
#define WAVE_KERNEL 0
#endif
const uint WAVE_NONE = 0xffffffffu;

// The path state: images 0-3 of glsl/path_state.glsl (path_write / path_load).
layout(std430, binding = 2) buffer WaveHits { uvec4 wave_hit[]; };  // t, tri + 1 (0: no hit), bary
layout(std430, binding = 3) buffer WaveTally { vec4 wave_tally[]; };  // 2 a slot: sum, dropped; sum2, cover
// Queues: the counts, then the long class from entry 0 and the short one from entry `slots`.
layout(std430, binding = 4) buffer WaveIn { uint in_long, in_short, in_pad0, in_pad1; uint in_slot[]; };
layout(std430, binding = 5) buffer WaveOut { uint out_long, out_short, out_pad0, out_pad1; uint out_slot[]; };
uniform int u_wave_start;  // 1: the draw's first shade, which starts every slot's first sample

uint wave_slots() { return uint(u_dispatch.z * u_dispatch.w); }
// The invocation's index: the host lays more than a row's worth of groups out in rows
// (mcpt/gpu/wavefront.py: GL guarantees only 65535 work groups along an axis).
uint wave_index() { return gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x; }
ivec2 wave_frag(uint p) { return u_dispatch.xy + ivec2(int(p) % u_dispatch.z, int(p) / u_dispatch.z); }

// Entry i of the input queue: the long class, then the short one; WAVE_NONE past both.
uint wave_queued(uint i) {
    if (i < in_long) return in_slot[i];
    i -= in_long;
    return i < in_short ? in_slot[wave_slots() + i] : WAVE_NONE;
}

void wave_enqueue(uint p, Ray r) {
    bool deep = true;
#if MCPT_BVH
    uvec4 lo = texelFetch(u_nodes, 0), hi = texelFetch(u_nodes, 1);  // the root's first child's box
    float tn;
    deep = box_hit(uintBitsToFloat(lo.xyz), uintBitsToFloat(hi.xyz), r.o, safe_inv(r.d), INF, tn);
#endif
    if (deep) out_slot[atomicAdd(out_long, 1u)] = p;
    else out_slot[wave_slots() + atomicAdd(out_short, 1u)] = p;
}

void wave_shade() {
    uint p = u_wave_start != 0 ? wave_index() : wave_queued(wave_index());
    if (p >= wave_slots()) return;
    ivec2 frag = wave_frag(p);
    int pix, tile_pix;
    ivec2 pixel = frag_pixel(frag, pix, tile_pix);
    Path P;
    int j = 0;
    Tally T = tally_start(vec3(0.0));  // main()'s, kept between kernels: a sample starts at 0
    if (u_wave_start != 0) {
        P = sample_start(pixel, pix, tile_pix, 0);
    } else {
        P = path_load(frag, j);
        vec4 a = wave_tally[2u * p], b = wave_tally[2u * p + 1u];
        T.sum = a.rgb; T.dropped = a.a; T.sum2 = b.rgb; T.cover = b.a;
        sampler_init(pix, tile_pix, j);
        uvec4 x = wave_hit[p];
        Hit h = Hit(uintBitsToFloat(x.x), x.y != 0u ? int(x.y) - 1 : -1, uintBitsToFloat(x.zw));
        if (!path_hit(P, P.ray, x.y != 0u, h)) {
            tally_sample(T, sample_value(P.L));
            if (++j >= u_samples) {  // the slot's samples are done: its tally goes to the targets
                tally_out(T);
                targets_add(frag);
                return;
            }
            P = sample_start(pixel, pix, tile_pix, j);
        }
    }
    path_write(frag, P, j);
    wave_tally[2u * p] = vec4(T.sum, T.dropped);
    wave_tally[2u * p + 1u] = vec4(T.sum2, T.cover);
    wave_enqueue(p, P.ray);
}

void wave_trace() {
    uint p = wave_queued(wave_index());
    if (p == WAVE_NONE) return;
    ivec2 at = wave_frag(p);
    Hit h;
    bool found = trace_closest(Ray(imageLoad(u_state0, at).xyz, imageLoad(u_state1, at).xyz), h);
    wave_hit[p] = uvec4(floatBitsToUint(h.t), found ? uint(h.tri + 1) : 0u, floatBitsToUint(h.bary));
}

void main() {
#if WAVE_KERNEL == 0
    wave_shade();
#else
    wave_trace();
#endif
}
