#include "sim/vec3.h"

namespace lockroll::sim {

namespace {
Fixed two_times(Fixed a) { return a * std::int64_t{2}; }

// Round a component to the 2^-30 grid (see renormalised()); saturates (and counts) at the ends
// of the range rather than overflow.
Fixed to_grid(Fixed f) {
    const std::int64_t g = round_shift(f.raw, 2);
    if (g > INT64_MAX / 4 || g < INT64_MIN / 4) {
        note_overflow();
        return g > 0 ? Fixed::max() : Fixed::min();
    }
    return Fixed::from_raw(g * 4);
}

// Round a component of |raw| below 2^35 (a small() quaternion's, or one times a factor within
// 2^-4 of 1) to the 2^-30 grid: to_grid()'s value, which saturates only beyond 2^61, without
// its range checks.
Fixed to_grid_small(Fixed f) { return Fixed::from_raw(round_shift(f.raw, 2) * 4); }

// v / 2^32 rounded as round_wide() rounds it, for |v| < 2^94: the quotient then fits in int64
// with room to spare, so round_wide's fast path always applies and its range checks (the
// quotient's fit, the round-up's overflow) are always passed: the same integer without them.
std::int64_t rounded_fits(i128 v) {
    const auto q = static_cast<std::uint64_t>(v >> 32);  // the floor, whole in 64 bits here
    const auto rem = static_cast<std::uint64_t>(v) & 0xFFFFFFFFu;
    return static_cast<std::int64_t>(q + (rem + (q & 1) > 0x80000000u));
}
// a b rounded (Fixed's operator*), for |a|, |b| <= 2^33 raw (|a b| <= 2^66 < 2^94).
std::int64_t times_small(std::int64_t a, std::int64_t b) { return rounded_fits(mul_wide(a, b)); }

// Every component within [-2, 2] (raw 2^33): rotation()'s products are then at most 4 and every
// sum and doubling in it at most 16 in magnitude, far inside Fixed's range.
inline bool within_two(const Quat& q) {
    constexpr std::uint64_t kTwo = std::uint64_t{1} << 33;
    const auto in = [](std::int64_t x) -> unsigned { return static_cast<std::uint64_t>(x) + kTwo <= 2 * kTwo; };
    return (in(q.w.raw) & in(q.x.raw) & in(q.y.raw) & in(q.z.raw)) != 0;  // one branch, not four
}

// b 2^32 + v rounded as round_wide() rounds it, for |b| < 2^34 and |v| < 2^63 (no saturation):
// the floor of the quotient by 2^32 is b + floor(v / 2^32), the remainder v's low 32 bits.
Fixed plus_scaled(std::int64_t b, std::int64_t v) {
    const std::int64_t q = b + (v >> 32);  // arithmetic shift: the floor
    const std::uint64_t rem = static_cast<std::uint64_t>(v) & 0xFFFFFFFFu;
    return Fixed::from_raw(q + static_cast<std::int64_t>(rem + static_cast<std::uint64_t>(q & 1) > 0x80000000u));
}
// x * f rounded (to nearest, ties to even, as round_wide), for f = 1 + d ulp and |x.raw d| < 2^62:
// a small() component (|x.raw| <= 2^34) with |d| < 2^28, or |x| <= 1 with |d| < kNearOne = 2^30.
// x.raw * f.raw = x.raw 2^32 + x.raw d, so the floor of its quotient by 2^32 is x.raw +
// floor(x.raw d / 2^32) and its remainder that of x.raw d: round_wide's integers, from the 64-bit
// product x.raw d instead of a 128-bit one. Quat.IntegratedShortcutsGiveTheGeneralBits compares
// renormalised() and integrated() with the 128-bit products.
constexpr std::int64_t kNearOne = std::int64_t{1} << 30;
Fixed times_one_plus(Fixed x, std::int64_t d) { return plus_scaled(x.raw, x.raw * d); }

// The Hamilton product dq q (operator*(Quat, Quat), the same bits) for a step's rotation dq =
// (c, v) close to 1 and q a rotation: c = 1 + dc ulp with |dc| + |v_x| + |v_y| + |v_z| below
// 2^30 raw (a half angle under about 1/4 rad: |w| under about 30 rad/s at 60 Hz) and q's
// components below 1.5 (raw 3 2^31). Each component of the product is c b_i plus three
// products v_k b_j, whose exact sum is b_i 2^32 + V with V = dc b_i + sum +-v_k b_j:
// |V| <= (|dc| + sum |v_k|) max |b| < 2^30 3 2^31 < 2^63, and so is every partial sum, in int64.
// The floor of the sum over 2^32 is b_i + floor(V / 2^32) and its low 32 bits are V's, the
// integers round_wide() rounds (to nearest, ties to even; no saturation this close to b_i):
// four 64-bit products a component instead of four 128-bit ones.
// Quat.NearOneProductGivesTheGeneralBits compares it with operator*.
bool near_one_times(const Quat& dq, const Quat& q) {
    constexpr std::uint64_t kStep = std::uint64_t{1} << 30, kQ = std::uint64_t{3} << 31;
    const auto in = [](std::int64_t x) -> unsigned {  // |x| < 1.5, as one unsigned comparison
        return static_cast<std::uint64_t>(x) + (kQ - 1) < 2 * kQ - 1;
    };
    // One branch, not eight.
    if ((in(q.w.raw) & in(q.x.raw) & in(q.y.raw) & in(q.z.raw) & in(dq.w.raw) & in(dq.x.raw) & in(dq.y.raw) & in(dq.z.raw)) == 0)
        return false;
    // Every component below 1.5: the magnitudes and their sum are far from wrapping.
    const auto mag = [](std::int64_t x) { return static_cast<std::uint64_t>(x < 0 ? -x : x); };
    return mag(dq.w.raw - Fixed::kOne) + mag(dq.x.raw) + mag(dq.y.raw) + mag(dq.z.raw) < kStep;
}
Quat near_one_product(const Quat& dq, const Quat& q) {
    const std::int64_t dc = dq.w.raw - Fixed::kOne, x = dq.x.raw, y = dq.y.raw, z = dq.z.raw;
    const std::int64_t bw = q.w.raw, bx = q.x.raw, by = q.y.raw, bz = q.z.raw;
    return {plus_scaled(bw, dc * bw - x * bx - y * by - z * bz), plus_scaled(bx, dc * bx + x * bw + y * bz - z * by),
            plus_scaled(by, dc * by - x * bz + y * bw + z * bx), plus_scaled(bz, dc * bz + x * by - y * bx + z * bw)};
}
}  // namespace

Mat3 rotation(const Quat& q) {
    if (within_two(q)) {
        // The general arithmetic below with nothing that can overflow or saturate (products at
        // most 4, sums and doublings at most 16): the same integers from plain int64 sums and
        // products rounded without range checks. Quat.RotationShortcutGivesTheGeneralBits.
        const std::int64_t w = q.w.raw, x = q.x.raw, y = q.y.raw, z = q.z.raw, one = Fixed::kOne;
        const std::int64_t xx = times_small(x, x), yy = times_small(y, y), zz = times_small(z, z);
        const std::int64_t xy = times_small(x, y), xz = times_small(x, z), yz = times_small(y, z);
        const std::int64_t wx = times_small(w, x), wy = times_small(w, y), wz = times_small(w, z);
        const auto f = [](std::int64_t r) { return Fixed::from_raw(r); };
        return {{{f(one - 2 * (yy + zz)), f(2 * (xy - wz)), f(2 * (xz + wy))},
                 {f(2 * (xy + wz)), f(one - 2 * (xx + zz)), f(2 * (yz - wx))},
                 {f(2 * (xz - wy)), f(2 * (yz + wx)), f(one - 2 * (xx + yy))}}};
    }
    return rotation_general(q);
}

Mat3 rotation_general(const Quat& q) {
    const Fixed one = Fixed::one();
    const Fixed xx = q.x * q.x, yy = q.y * q.y, zz = q.z * q.z;
    const Fixed xy = q.x * q.y, xz = q.x * q.z, yz = q.y * q.z;
    const Fixed wx = q.w * q.x, wy = q.w * q.y, wz = q.w * q.z;
    return {{{one - two_times(yy + zz), two_times(xy - wz), two_times(xz + wy)},
             {two_times(xy + wz), one - two_times(xx + zz), two_times(yz - wx)},
             {two_times(xz - wy), two_times(yz + wx), one - two_times(xx + yy)}}};
}

Mat3 rotate_diagonal(const Mat3& r, const Vec3& d) {
    Vec3 a[3];
    for (int i = 0; i < 3; ++i) a[i] = {r.row[i].x * d.x, r.row[i].y * d.y, r.row[i].z * d.z};
    const Fixed m00 = dot(a[0], r.row[0]), m01 = dot(a[0], r.row[1]), m02 = dot(a[0], r.row[2]);
    const Fixed m11 = dot(a[1], r.row[1]), m12 = dot(a[1], r.row[2]), m22 = dot(a[2], r.row[2]);
    return {{{m00, m01, m02}, {m01, m11, m12}, {m02, m12, m22}}};
}

// R's entries for within_two(q) are at most 16 in magnitude (1 - 2 (yy + zz) >= -15, 2 (xy + wz)
// <= 16: raw 2^36), so for |v_i| < 2^55 raw each dot's three exact products are below 2^91 and
// their sum below 2^93: dot()'s checked sums never overflow and its rounding never saturates,
// the same integers as rounded_fits() of the plain sum. Quat.RotateScaledGivesTheGeneralBits.
Vec3 rotate_scaled(const Quat& q, const Mat3& r, const Vec3& d, const Vec3& l) {
    constexpr std::uint64_t kV = std::uint64_t{1} << 55;
    const auto below = [](Fixed x) -> unsigned { return static_cast<std::uint64_t>(x.raw) + kV < 2 * kV; };
    const auto tame = [&](const Vec3& v) { return (below(v.x) & below(v.y) & below(v.z)) != 0; };
    const auto dot3 = [](const Vec3& a, Fixed b0, Fixed b1, Fixed b2) {
        return Fixed::from_raw(rounded_fits(mul_wide(a.x.raw, b0.raw) + mul_wide(a.y.raw, b1.raw) + mul_wide(a.z.raw, b2.raw)));
    };
    if (!within_two(q) || !tame(l)) {
        const Vec3 t = transpose_times(r, l);
        return r * Vec3{d.x * t.x, d.y * t.y, d.z * t.z};
    }
    const Vec3& r0 = r.row[0];
    const Vec3& r1 = r.row[1];
    const Vec3& r2 = r.row[2];
    const Vec3 t{dot3(l, r0.x, r1.x, r2.x), dot3(l, r0.y, r1.y, r2.y), dot3(l, r0.z, r1.z, r2.z)};
    const Vec3 b{d.x * t.x, d.y * t.y, d.z * t.z};
    if (!tame(b)) return r * b;
    return {dot3(b, r0.x, r0.y, r0.z), dot3(b, r1.x, r1.y, r1.z), dot3(b, r2.x, r2.y, r2.z)};
}

Quat renormalised(const Quat& q) {
    const bool small = quat_detail::small(q);
    const Fixed s = small ? quat_detail::sum4_small(q.w.raw, q.w.raw, q.x.raw, q.x.raw, q.y.raw, q.y.raw, q.z.raw, q.z.raw)
                          : quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
    const Fixed f = Fixed::from_raw((3 * Fixed::kOne - s.raw) / 2);  // |s - 1| is tiny: no overflow
    // |q|^2 within an ulp of 1 gives f = 1 exactly, and x * 1 is x bit for bit (raw * 2^32,
    // shifted back with nothing to round, never out of range): the four products are skipped.
    if (f == Fixed::one()) {
        if (small) return {to_grid_small(q.w), to_grid_small(q.x), to_grid_small(q.y), to_grid_small(q.z)};
        return {to_grid(q.w), to_grid(q.x), to_grid(q.y), to_grid(q.z)};
    }
    // A product's |q|^2 leaves 1 by a few ulps, so f = 1 + d ulp with d small: the products
    // x * f are taken as x + x d / 2^32 in 64 bits (the same rounded value, see times_one_plus).
    const std::int64_t d = f.raw - Fixed::kOne;
    if (small && d > -kNearOne / 4 && d < kNearOne / 4)
        // x (1 + d ulp) with |x| <= 4, |d| < 2^28: within 4 (1 + 2^-4) plus an ulp, raw below 2^34.1,
        // nowhere near to_grid's saturation.
        return {to_grid_small(times_one_plus(q.w, d)), to_grid_small(times_one_plus(q.x, d)),
                to_grid_small(times_one_plus(q.y, d)), to_grid_small(times_one_plus(q.z, d))};
    return {to_grid(q.w * f), to_grid(q.x * f), to_grid(q.y * f), to_grid(q.z * f)};
}

// integrated()'s step rotation for a tame rate: every |w_i| and |dt / 2| below 2^40 and 2^31
// raw (256 rad/s, 1/2 s) and every |a_i| = |w_i dt / 2| within 2^30 raw (1/4 rad). Then no
// product or sum below can overflow or saturate: w_i dt / 2 is below 2^71 (rounded_fits), a_i^2
// below 2^60 and s = |a|^2 below 3 2^28 raw (3/16, under 1: no capping), s k6 below 2^60, s^2
// below 9 2^56, s^3 below 2^57 and every coefficient product below 2^57, all in int64; each
// rounded as round_wide() rounds it (plus_scaled(0, v): to nearest, ties to even) and the sums
// of c and k far inside the range: the general arithmetic's integers without its 128-bit
// products and range checks. False (nothing computed, nothing counted) outside those bounds.
// Quat.TameRateShortcutGivesTheGeneralBits compares it with the general arithmetic (through
// quat_detail::tame_half_turn; integrated() has it inline).
namespace {
[[gnu::always_inline]] inline bool tame_half_turn(const Vec3& w, Fixed half_dt, Vec3& a_out, Fixed& c_out, Fixed& k_out) {
    constexpr std::uint64_t kW = std::uint64_t{1} << 40, kH = std::uint64_t{1} << 31, kA = std::uint64_t{1} << 30;
    const auto within = [](std::int64_t x, std::uint64_t b) -> unsigned {  // -b <= x < b
        return static_cast<std::uint64_t>(x) + b < 2 * b;
    };
    if ((within(w.x.raw, kW) & within(w.y.raw, kW) & within(w.z.raw, kW) & within(half_dt.raw, kH)) == 0) return false;
    const std::int64_t ax = rounded_fits(mul_wide(w.x.raw, half_dt.raw));
    const std::int64_t ay = rounded_fits(mul_wide(w.y.raw, half_dt.raw));
    const std::int64_t az = rounded_fits(mul_wide(w.z.raw, half_dt.raw));
    if ((within(ax, kA) & within(ay, kA) & within(az, kA)) == 0) return false;
    const auto r = [](std::int64_t v) { return plus_scaled(0, v).raw; };  // v / 2^32 rounded
    const quat_detail::SeriesCoefficients& k_ = quat_detail::kSeries;
    const std::int64_t s = r(ax * ax + ay * ay + az * az);
    std::int64_t c = Fixed::kOne - s / 2, k = Fixed::kOne - r(s * k_.k6.raw);
    if (s > k_.s2_terms_zero_up_to) {  // the thresholds as in integrated()
        const std::int64_t s2 = r(s * s);
        c += r(s2 * k_.c24.raw);
        k += r(s2 * k_.k120.raw);
        if (s > k_.s3_terms_zero_up_to) {
            const std::int64_t s3 = r(s2 * s);
            c -= r(s3 * k_.c720.raw);
            k -= r(s3 * k_.k5040.raw);
        }
    }
    a_out = {Fixed::from_raw(ax), Fixed::from_raw(ay), Fixed::from_raw(az)};
    c_out = Fixed::from_raw(c);
    k_out = Fixed::from_raw(k);
    return true;
}

// The step's rotation dq = (c, a k) applied to q, renormalised (integrated()'s tail).
Quat turned(const Quat& q, const Vec3& a, Fixed s, Fixed c, Fixed k) {
    // k = 1 + d ulp with -2^30 < d <= 0 for s <= 1, and |a| <= 1: a * k in 64 bits
    // (times_one_plus; |a.raw d| < 2^62), the same rounded value as the 128-bit product.
    const std::int64_t d = k.raw - Fixed::kOne;
    const Quat dq = s <= Fixed::one() && d > -kNearOne && d <= 0
                        ? Quat{c, times_one_plus(a.x, d), times_one_plus(a.y, d), times_one_plus(a.z, d)}
                        : Quat{c, a.x * k, a.y * k, a.z * k};
    return renormalised(near_one_times(dq, q) ? near_one_product(dq, q) : dq * q);
}
}  // namespace

bool quat_detail::tame_half_turn(const Vec3& w, Fixed half_dt, Vec3& a, Fixed& c, Fixed& k) {
    return lockroll::sim::tame_half_turn(w, half_dt, a, c, k);
}

Quat integrated(const Quat& q, const Vec3& w, Fixed dt) {
    // a = w dt / 2 (the half angle as a vector); s = |a|^2.
    const Fixed half_dt = Fixed::from_raw(dt.raw / 2);
    {
        Vec3 a;
        Fixed c, k;
        // s (at most 3/16 there) only decides turned()'s 64-bit products: any s <= 1 will do.
        if (tame_half_turn(w, half_dt, a, c, k)) return turned(q, a, Fixed::zero(), c, k);
    }
    Vec3 a = w * half_dt;
    Fixed s = dot(a, a);
    // The series below is for small angles. A body spun past any sane rate (a half angle above
    // 1 rad a step: 120 rad/s at 60 Hz; a fuzzed scene reached it) turns by 2 rad this step
    // about the same axis, so q stays a rotation instead of growing without bound. Exact
    // integer square root and division: the same bits everywhere.
    if (s > Fixed::one()) {
        const Fixed len = length(a);
        a = {a.x / len, a.y / len, a.z / len};
        s = dot(a, a);
    }
    // cos|a| = 1 - s/2 + s^2/24 - s^3/720;  sin|a| / |a| = 1 - s/6 + s^2/120 - s^3/5040.
    // A slowly turning body (a ball rolling or lying in a pile) has s small enough that the s^3
    // terms (or the s^2 and s^3 terms) each round to exactly 0 (below half an ulp, 2^-33), and
    // x + 0 and x - 0 are x: those terms, and the powers they need, are not computed. Every step
    // of the rounded chain (s^2 = s * s, s^3 = s^2 * s, then times the coefficient) is
    // nondecreasing in s >= 0, so "this power's terms round to 0" holds for every s up to a
    // largest one (quat_detail::kSeries). The same bits, not an approximation:
    // Quat.IntegratedShortcutsGiveTheGeneralBits, Quat.SeriesThresholdsAreTheLargestExact.
    constexpr const quat_detail::SeriesCoefficients& k_ = quat_detail::kSeries;
    Fixed c = Fixed::one() - Fixed::from_raw(s.raw / 2);
    Fixed k = Fixed::one() - s * k_.k6;
    if (s.raw > k_.s2_terms_zero_up_to) {
        const Fixed s2 = s * s;
        c = c + s2 * k_.c24;
        k = k + s2 * k_.k120;
        if (s.raw > k_.s3_terms_zero_up_to) {
            const Fixed s3 = s2 * s;
            c = c - s3 * k_.c720;
            k = k - s3 * k_.k5040;
        }
    }
    return turned(q, a, s, c, k);
}

Quat normalised(const Quat& q) {
    const u128 sq = length_sq_wide({q.w, q.x, q.y}) + static_cast<u128>(mul_wide(q.z.raw, q.z.raw));
    if (sq == 0) return Quat{};
    const Fixed len = sqrt_wide(sq);
    return renormalised({q.w / len, q.x / len, q.y / len, q.z / len});
}

}  // namespace lockroll::sim
