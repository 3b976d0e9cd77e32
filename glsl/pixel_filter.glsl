// Pixel filter by importance sampling (host: mcpt/shading/pixel_filter.py, which says why): the
// camera sample's offset from its pixel's centre, drawn per axis by the filter's inverse CDF, cut
// to the film as Mitsuba's film keeps only samples on it. MCPT_FILTER 1 tent, 2 Gaussian (0, the
// box, compiles none of this). No table search: closed forms, and Newton's method for the Gaussian.
uniform float u_filter_radius;   // pixels
// CDF at the film's first edge seen from the k-th pixel column (row) from it, i.e. at offset
// -(k + 0.5), for the u_filter_edges columns within the radius; by symmetry 1 - the CDF at the
// last edge. Computed on the host.
#define FILTER_EDGES 16
uniform float u_filter_edge[FILTER_EDGES];
uniform int u_filter_edges;

#if MCPT_FILTER == 2
uniform float u_gauss_s;         // stddev * sqrt(2), pixels
uniform float u_gauss_bias;      // exp(-r^2 / (2 stddev^2)): Mitsuba lowers the Gaussian by it
uniform float u_gauss_erfc_r;    // erfc(r / s)
uniform float u_gauss_norm;      // the filter's integral over [-r, r]

// erfc(z) for z >= 0, fractional error < 1.2e-7 everywhere (Numerical Recipes' erfcc, after
// Chebyshev fitting): relative precision in the tails, where the CDF is small.
float gauss_erfc(float z) {
    float t = 1.0 / (1.0 + 0.5 * z);
    float p = -1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (-0.18628806
              + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    return t * exp(-z * z + p);
}

// erfinv(1 - y) for y in (0, 1] without forming 1 - y (M. Giles 2010, "Approximating the erfinv
// function", GPU Computing Gems, single-precision version; w = -log((1 - x)(1 + x)) = -log(y (2 - y))).
float gauss_erfcinv(float y) {
    float w = -log(y * (2.0 - y)), p;
    if (w < 5.0) {
        w -= 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w; p = -3.5233877e-06 + p * w; p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w; p = -0.00125372503 + p * w; p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w; p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w; p = 0.00134934322 + p * w; p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w; p = -0.0076224613 + p * w; p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w; p = 2.83297682 + p * w;
    }
    return p * (1.0 - y);
}

// One Newton step toward G(x) = target on [-r, 0] (G below).
float gauss_newton(float x, float target) {
    float s = u_gauss_s, r = u_filter_radius;
    float g = 0.5 * s * sqrt(PI) * (gauss_erfc(-x / s) - u_gauss_erfc_r) - u_gauss_bias * (x + r);
    float f = max(exp(-(x * x) / (s * s)) - u_gauss_bias, 1e-30);
    return clamp(x - (g - target) / f, -r, 0.0);
}

// Offset with CDF c of Mitsuba's Gaussian max(0, exp(-x^2/s^2) - bias) on [-r, r]. Its integral from
// -r to x <= 0 is G(x) = s sqrt(pi)/2 (erfc(|x|/s) - erfc(r/s)) - bias (x + r); the lower half is
// solved (c > 1/2 by symmetry, keeping the precision of small CDFs): the plain Gaussian's inverse
// as the start, then Newton steps on G (CDF error < 3e-7 where c > 1e-3, < 1e-5 beyond).
float filter_invert(float c) {
    bool upper = c > 0.5;
    float target = (upper ? 1.0 - c : c) * u_gauss_norm;
    float s = u_gauss_s, r = u_filter_radius;
    float x = clamp(-s * gauss_erfcinv(target / (0.5 * s * sqrt(PI)) + u_gauss_erfc_r), -r, 0.0);
    // At x, G(x) = target - bias (x + r) up to erfcinv's error: a Newton step on the bias alone
    // needs no erfc; then one full step.
    x = clamp(x + u_gauss_bias * (x + r) / max(exp(-(x * x) / (s * s)) - u_gauss_bias, 1e-30), -r, 0.0);
    x = gauss_newton(x, target);
    return upper ? -x : x;
}
#else
// The tent's inverse CDF: (x + r)^2 / (2 r^2) below 0, 1 - (r - x)^2 / (2 r^2) above.
float filter_invert(float c) {
    float r = u_filter_radius;
    return c < 0.5 ? r * (sqrt(2.0 * c) - 1.0) : r * (1.0 - sqrt(2.0 - 2.0 * c));
}
#endif

// Offset for u in [0, 1) restricted to the film, for the pixel `from_first` columns (or rows)
// from its first edge and `from_last` from its last: u maps into [CDF(lo), CDF(hi)].
float filter_offset(float u, int from_first, int from_last) {
    float c0 = from_first < u_filter_edges ? u_filter_edge[min(from_first, FILTER_EDGES - 1)] : 0.0;
    float c1 = from_last < u_filter_edges ? 1.0 - u_filter_edge[min(from_last, FILTER_EDGES - 1)] : 1.0;
    return filter_invert(c0 + u * (c1 - c0));
}

// The sample's position inside pixel `pixel` (pixels, 0.5 = the centre; may leave [0, 1) by up
// to the radius) for the camera's two random numbers u, on a film of `res` pixels.
vec2 filter_jitter(ivec2 pixel, vec2 u, ivec2 res) {
    ivec2 far = res - 1 - pixel;
    return 0.5 + vec2(filter_offset(u.x, pixel.x, far.x), filter_offset(u.y, pixel.y, far.y));
}
