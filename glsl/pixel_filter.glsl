// Pixel filter by importance sampling (host: mcpt/shading/pixel_filter.py, which derives the
// table and says why): the camera sample's offset from its pixel's centre, drawn per axis from the
// filter's piecewise-linear density (exact for the tent, 3e-4 of the Gaussian's integral), truncated
// to the film as Mitsuba's film keeps only samples on it. Compiled only with MCPT_FILTER (not box).
#define FILTER_KNOTS 129
uniform float u_filter_x[FILTER_KNOTS];    // knots, pixels, ascending over [-radius, radius]
uniform float u_filter_pdf[FILTER_KNOTS];  // normalised density at each knot (1 / pixel)
uniform float u_filter_cdf[FILTER_KNOTS];  // integral up to each knot; unused entries 2.0
uniform int u_filter_last;                 // index of the last knot

// The segment [x_i, x_i+1] whose CDF range holds c: the largest i < last with cdf[i] <= c.
// Written out (seven fixed steps over 128 segments): a loop would spend llvmpipe's loop budget
// (glsl/common.glsl LOOP_TICK) without being counted.
#define FILTER_STEP(table, v, s) if (i + s < u_filter_last && table[i + s] <= v) i += s
int filter_segment_cdf(float c) {
    int i = 0;
    FILTER_STEP(u_filter_cdf, c, 64);
    FILTER_STEP(u_filter_cdf, c, 32);
    FILTER_STEP(u_filter_cdf, c, 16);
    FILTER_STEP(u_filter_cdf, c, 8);
    FILTER_STEP(u_filter_cdf, c, 4);
    FILTER_STEP(u_filter_cdf, c, 2);
    FILTER_STEP(u_filter_cdf, c, 1);
    return i;
}

// The largest i < last with x_i <= v.
int filter_segment_x(float v) {
    int i = 0;
    FILTER_STEP(u_filter_x, v, 64);
    FILTER_STEP(u_filter_x, v, 32);
    FILTER_STEP(u_filter_x, v, 16);
    FILTER_STEP(u_filter_x, v, 8);
    FILTER_STEP(u_filter_x, v, 4);
    FILTER_STEP(u_filter_x, v, 2);
    FILTER_STEP(u_filter_x, v, 1);
    return i;
}

// CDF at offset v (pixels): the segment's start plus the trapezoid up to v.
float filter_cdf(float v) {
    v = clamp(v, u_filter_x[0], u_filter_x[u_filter_last]);
    int i = filter_segment_x(v);
    float h = u_filter_x[i + 1] - u_filter_x[i], s = v - u_filter_x[i];
    return u_filter_cdf[i] + s * (u_filter_pdf[i] + 0.5 * (u_filter_pdf[i + 1] - u_filter_pdf[i]) * s / h);
}

// Offset (pixels) of CDF value c: in its segment the density is p + k s, whose integral p s + k s^2 / 2
// = d is solved in the cancellation-free form s = 2 d / (p + sqrt(p^2 + 2 k d)).
float filter_invert(float c) {
    int i = filter_segment_cdf(c);
    float h = u_filter_x[i + 1] - u_filter_x[i];
    float p = u_filter_pdf[i], k = (u_filter_pdf[i + 1] - p) / h, d = max(c - u_filter_cdf[i], 0.0);
    float s = 2.0 * d / max(p + sqrt(max(p * p + 2.0 * k * d, 0.0)), 1e-30);
    return u_filter_x[i] + clamp(s, 0.0, h);
}

// Offset for u in [0, 1) restricted to [lo, hi] (what keeps the sample on the film); a pixel
// farther than the radius from the edge skips the two CDF look-ups.
float filter_offset(float u, float lo, float hi) {
    float c0 = lo > u_filter_x[0] ? filter_cdf(lo) : 0.0;
    float c1 = hi < u_filter_x[u_filter_last] ? filter_cdf(hi) : 1.0;
    return filter_invert(c0 + u * (c1 - c0));
}

// The sample's position inside pixel `pixel` (pixels, 0.5 = the centre; may leave [0, 1) by up
// to the radius) for the camera's two random numbers u, on a film of `res` pixels.
vec2 filter_jitter(ivec2 pixel, vec2 u, ivec2 res) {
    vec2 c = vec2(pixel) + 0.5;
    return 0.5 + vec2(filter_offset(u.x, -c.x, float(res.x) - c.x),
                      filter_offset(u.y, -c.y, float(res.y) - c.y));
}
