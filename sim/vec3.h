// The physics world's vector math: Vec3, a body's orientation (Quat, a unit quaternion) and the
// 3x3 matrices built from it, all in Q32.32 (sim/fixed.h).
//
// Vec3: dot products and lengths accumulate exact 128-bit products and round once, so |v| and
// v.w are correctly rounded, not the sum of three roundings.
//
// Contract (Quat, Mat3)
//  - Quat{w, x, y, z} rotates v to q v q*; products and rotations sum their exact 128-bit
//    products and round once per component (as dot() does), so they are correctly rounded sums.
//  - renormalised(q) brings |q| back to 1 with one Newton step, q * (3 - |q|^2) / 2, and then
//    rounds every component to a multiple of 2^-30 (ties to even). No square root, no division:
//    the same integers on every target. One step is enough because a step's rotation moves |q|
//    by rounding only (~1e-9); the quadratic convergence then leaves the length within rounding.
//    The 2^-30 grid is what a snapshot stores: each component fits an int32, so orientation
//    costs 16 bytes per body, not 32 (sim/snapshot.h), and saving loses nothing.
//  - integrated(q, w, dt) turns q by the angular velocity w (world frame, rad/s) over dt with
//    the exponential map exp(w dt / 2) q, its sine and cosine from their Taylor series to
//    a^6 (|w dt| = 1 rad errs by 3e-8 before renormalisation). Exact for a constant w. A turn
//    of more than 2 rad in one step is capped at 2 rad about the same axis (the series would
//    diverge); w itself is left as it is.
//  - No float or double anywhere.
#pragma once

#include <lockroll/sim/fixed.h>

namespace lockroll::sim {

struct Vec3 {
    Fixed x, y, z;

    friend constexpr bool operator==(const Vec3&, const Vec3&) = default;
};

// Component k of v (0 = x, 1 = y, 2 = z): for code that picks an axis at run time (axis codes,
// box faces). k outside 0..2 reads z.
inline Fixed& component(Vec3& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
inline Fixed component(const Vec3& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
// v * s, v += d and v -= d always inline: gcc's per-file inlining budget (inline-unit-growth)
// otherwise runs out in sim/rigid_solver.cpp and calls them from the solver's loop, a 24-byte
// Vec3 returned through memory (issue 19). Only these three: forcing +, - and s * v inline too
// cost the particle scenes' step (docs/performance.md, "Review fixes, same bits"). The compound
// ones are written componentwise so that they need no other operator inlined.
// [[gnu::always_inline]] as elsewhere in sim/ (gcc and clang; other compilers ignore it).
[[gnu::always_inline]] inline Vec3 operator*(const Vec3& a, Fixed s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(Fixed s, const Vec3& a) { return a * s; }
[[gnu::always_inline]] inline Vec3& operator+=(Vec3& a, const Vec3& b) { return a = {a.x + b.x, a.y + b.y, a.z + b.z}; }
[[gnu::always_inline]] inline Vec3& operator-=(Vec3& a, const Vec3& b) { return a = {a.x - b.x, a.y - b.y, a.z - b.z}; }

// Sum of exact products in Q64.64. Returns false, with *out saturated to +-(2^127 - 1), when a
// partial sum leaves the i128 range. The total is then at least 2^126 in magnitude (a third
// product is at most 2^126), so far beyond Fixed's range either way, with the partial's sign.
inline bool dot_wide_checked(const Vec3& a, const Vec3& b, i128* out) {
    constexpr i128 kWideMax = static_cast<i128>(~u128{0} >> 1);
    i128 s = mul_wide(a.x.raw, b.x.raw);
    i128 t;
    if (add_overflow(s, mul_wide(a.y.raw, b.y.raw), &t)) {
        *out = s > 0 ? kWideMax : -kWideMax;
        return false;
    }
    if (add_overflow(t, mul_wide(a.z.raw, b.z.raw), &s)) {
        *out = t > 0 ? kWideMax : -kWideMax;
        return false;
    }
    *out = s;
    return true;
}

// a.b in Q64.64, saturating (and counting) only if the i128 sum itself would overflow.
inline i128 dot_wide(const Vec3& a, const Vec3& b) {
    i128 s;
    if (!dot_wide_checked(a, b, &s)) note_overflow();
    return s;
}

// a.b correctly rounded; a saturated result counts as exactly one overflow event.
inline Fixed dot(const Vec3& a, const Vec3& b) {
    i128 s;
    if (!dot_wide_checked(a, b, &s)) {
        note_overflow();
        return s > 0 ? Fixed::max() : Fixed::min();
    }
    return round_wide(s);
}

// a x b, each component rounded once.
inline Vec3 cross(const Vec3& a, const Vec3& b) {
    const auto c = [](Fixed p, Fixed q, Fixed r, Fixed s) {  // p q - r s, rounded once
        return round_wide(mul_wide(p.raw, q.raw) - mul_wide(r.raw, s.raw));
    };
    return {c(a.y, b.z, a.z, b.y), c(a.z, b.x, a.x, b.z), c(a.x, b.y, a.y, b.x)};
}

// |v|^2 in Q64.64 (exact, never overflows: 3 * 2^126 < 2^128).
inline u128 length_sq_wide(const Vec3& v) {
    auto sq = [](Fixed f) {
        const std::uint64_t m = f.raw < 0 ? 0 - static_cast<std::uint64_t>(f.raw) : static_cast<std::uint64_t>(f.raw);
        return mul_wide_unsigned(m, m);
    };
    return sq(v.x) + sq(v.y) + sq(v.z);
}

// |v|, correctly rounded; saturates (and counts) only beyond Fixed::max().
inline Fixed length(const Vec3& v) {
    const std::uint64_t r = isqrt_round(length_sq_wide(v));
    if (r > static_cast<std::uint64_t>(INT64_MAX)) { note_overflow(); return Fixed::max(); }
    return Fixed::from_raw(static_cast<std::int64_t>(r));
}

// ---- orientation ----

struct Quat {
    Fixed w = Fixed::one(), x, y, z;

    friend constexpr bool operator==(const Quat&, const Quat&) = default;
};

// Row-major 3x3 matrix (rotations and world-space inverse inertia).
struct Mat3 {
    Vec3 row[3];
};

namespace quat_detail {
// Exact sum of four Q32.32 products, rounded once (saturating and counting only beyond range).
// A unit quaternion's products are tiny, but a body spun past any sane rate (a fuzzed scene
// found one) integrates to components far from 1, so every partial sum is checked: the fourth
// product could otherwise overflow i128, which is undefined behaviour, not just a wrong result.
inline Fixed sum4(Fixed a0, Fixed b0, Fixed a1, Fixed b1, Fixed a2, Fixed b2, Fixed a3, Fixed b3) {
    i128 s, t;
    if (!dot_wide_checked({a0, a1, a2}, {b0, b1, b2}, &s) || add_overflow(s, mul_wide(a3.raw, b3.raw), &t)) {
        note_overflow();
        return s > 0 ? Fixed::max() : Fixed::min();
    }
    return round_wide(t);
}
// Every component in [-4, 4] (a rotation's are in [-1, 1]): then each product is below 2^68
// and a sum of four below 2^70, so nothing can overflow or saturate and the checked sums above
// give exactly the plain ones.
inline bool small(const Quat& q) {
    constexpr std::uint64_t kBound = std::uint64_t{1} << 34;  // 4.0 in Q32.32
    const auto in = [](Fixed f) -> unsigned { return static_cast<std::uint64_t>(f.raw) + kBound <= 2 * kBound; };
    return (in(q.w) & in(q.x) & in(q.y) & in(q.z)) != 0;  // one branch, not four
}
// a0 b0 + a1 b1 + a2 b2 + a3 b3 rounded once, for small() operands: sum4's value without its
// overflow checks (the integration of every turning body runs one Hamilton product a step).
inline Fixed sum4_small(std::int64_t a0, std::int64_t b0, std::int64_t a1, std::int64_t b1, std::int64_t a2,
                        std::int64_t b2, std::int64_t a3, std::int64_t b3) {
    return round_wide(mul_wide(a0, b0) + mul_wide(a1, b1) + mul_wide(a2, b2) + mul_wide(a3, b3));
}

// integrated()'s series coefficients (cos|a| = 1 - s/2 + s^2 c24 - s^3 c720, sin|a|/|a| =
// 1 - s k6 + s^2 k120 - s^3 k5040, s = |a|^2: Fixed::ratio(1, n)'s raw values) and the largest
// s.raw up to which the s^2 and s^3 terms (the s^3 terms) all round to exactly 0, so that
// integrated() does not compute them. Rounded powers and products are nondecreasing in s >= 0,
// so "these terms round to 0" holds for every s up to a largest one. Constants rather than
// computed at start-up (no static-initialisation order to get wrong); tests/sim/quat_test.cpp
// (Quat.SeriesThresholdsAreTheLargestExact) checks each against Fixed::ratio and the general
// arithmetic: true at the threshold, false one ulp above.
struct SeriesCoefficients {
    Fixed c24, c720, k6, k120, k5040;
    std::int64_t s2_terms_zero_up_to, s3_terms_zero_up_to;
};
inline constexpr SeriesCoefficients kSeries{Fixed::from_raw(178956971), Fixed::from_raw(5965232),
                                            Fixed::from_raw(715827883), Fixed::from_raw(35791394),
                                            Fixed::from_raw(852176),    222243,  // s = 5.17e-5
                                            18805087};                           // s = 4.378e-3
// integrated()'s half angle a = w dt / 2 and its series c (cos|a|) and k (sin|a| / |a|) for a
// tame rate (|w_i| < 2^40, |half_dt| < 2^31, |a_i| <= 2^30 raw), the general arithmetic's bits
// by 64-bit products; false, with nothing computed or counted, for any other (sim/quat.cpp).
bool tame_half_turn(const Vec3& w, Fixed half_dt, Vec3& a, Fixed& c, Fixed& k);
}  // namespace quat_detail

// Hamilton product a b (apply b, then a).
inline Quat operator*(const Quat& a, const Quat& b) {
    using quat_detail::sum4;
    if (quat_detail::small(a) && quat_detail::small(b)) {
        using quat_detail::sum4_small;
        const std::int64_t aw = a.w.raw, ax = a.x.raw, ay = a.y.raw, az = a.z.raw;
        const std::int64_t bw = b.w.raw, bx = b.x.raw, by = b.y.raw, bz = b.z.raw;
        return {sum4_small(aw, bw, -ax, bx, -ay, by, -az, bz), sum4_small(aw, bx, ax, bw, ay, bz, -az, by),
                sum4_small(aw, by, -ax, bz, ay, bw, az, bx), sum4_small(aw, bz, ax, by, -ay, bx, az, bw)};
    }
    return {sum4(a.w, b.w, -a.x, b.x, -a.y, b.y, -a.z, b.z), sum4(a.w, b.x, a.x, b.w, a.y, b.z, -a.z, b.y),
            sum4(a.w, b.y, -a.x, b.z, a.y, b.w, a.z, b.x), sum4(a.w, b.z, a.x, b.y, -a.y, b.x, a.z, b.w)};
}

inline Vec3 operator*(const Mat3& m, const Vec3& v) { return {dot(m.row[0], v), dot(m.row[1], v), dot(m.row[2], v)}; }

// m^T v.
inline Vec3 transpose_times(const Mat3& m, const Vec3& v) {
    return {dot({m.row[0].x, m.row[1].x, m.row[2].x}, v), dot({m.row[0].y, m.row[1].y, m.row[2].y}, v),
            dot({m.row[0].z, m.row[1].z, m.row[2].z}, v)};
}

// The rotation matrix of a unit quaternion (its columns are the body axes in world space).
Mat3 rotation(const Quat& q);
// rotation()'s general arithmetic (every product and sum range-checked); rotation() gives the
// same bits by a shorter path for a quaternion with every component within [-2, 2] (the tests
// compare).
Mat3 rotation_general(const Quat& q);

// R diag(d) R^T: a body-frame diagonal tensor (inverse inertia) in world space. Symmetric.
Mat3 rotate_diagonal(const Mat3& r, const Vec3& d);

// R diag(d) R^T l for R = rotation(q) (a body's world-frame inverse inertia times l): the
// bits of r * {d.x t.x, d.y t.y, d.z t.z} with t = transpose_times(r, l). With q's components
// within [-2, 2] R's entries are at most 16 and a vector's dots need no overflow checks when
// its components are below 2^55 raw (sim/quat.cpp); any other case goes the general way.
Vec3 rotate_scaled(const Quat& q, const Mat3& r, const Vec3& d, const Vec3& l);

Quat renormalised(const Quat& q);
Quat integrated(const Quat& q, const Vec3& angular_velocity, Fixed dt);

// Deterministic unit-length normalisation of a scene's orientation (exact square root and
// division, correctly rounded, then renormalised()); a zero quaternion gives the identity.
Quat normalised(const Quat& q);

}  // namespace lockroll::sim
