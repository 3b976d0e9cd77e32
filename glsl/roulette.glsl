// Russian roulette on the throughput (host side: mcpt/shading/roulette.py, which holds
// MCPT_RR_START and the rule's sources). Unbiased: a survivor's throughput is divided by its
// survival probability q. Compiled only where paths may be long enough (MCPT_RR).
#include "path_state.glsl"
#include "sampler.glsl"

// After scattering at hit k (P.beta already holds the sample's weight): false when the path
// ends here. Radiance inside glass is scaled by 1/eta^2, which says nothing about the path's
// future: undone through P.eta_scale (pbrt-v4).
bool roulette(inout Path P, int k, int dim) {
#if MCPT_RR
    if (k >= MCPT_RR_START) {
#if MCPT_TRANSMISSION
        vec3 rb = P.beta * P.eta_scale;
#else
        vec3 rb = P.beta;
#endif
        // pbrt-v4's rule: only a path whose (eta-corrected) throughput fell below 1 plays,
        // and it survives with exactly that probability, with no cap below 1. A cap (we had
        // 0.95, as Mitsuba 3) makes survivors' weights grow by albedo/cap per bounce, a
        // heavy-tailed estimate that at albedo 0.999 practically never reaches its mean
        // (issue #10: furnace at 1000 bounces gave 221 for 632.67).
        float q = max(rb.r, max(rb.g, rb.b));
        if (q < 1.0) {
            if (rand_at(dim + DIM_RR) >= q) return false;
            P.beta /= q;
        }
    }
#endif
    return true;
}
