#include "sim/vec3.h"

namespace lockroll::sim {

namespace {
Fixed two_times(Fixed a) { return a * std::int64_t{2}; }

// a * b, without the product when a is exactly 0 (then a * b is exactly 0: round(0) = 0, and
// nothing overflows).
Fixed times_nonzero(Fixed a, Fixed b) { return a.raw == 0 ? Fixed::zero() : a * b; }

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
}  // namespace

Mat3 rotation(const Quat& q) {
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

Quat renormalised(const Quat& q) {
    const Fixed s = quat_detail::small(q)
                        ? quat_detail::sum4_small(q.w.raw, q.w.raw, q.x.raw, q.x.raw, q.y.raw, q.y.raw, q.z.raw, q.z.raw)
                        : quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
    const Fixed f = Fixed::from_raw((3 * Fixed::kOne - s.raw) / 2);  // |s - 1| is tiny: no overflow
    // |q|^2 within an ulp of 1 gives f = 1 exactly, and x * 1 is x bit for bit (raw * 2^32,
    // shifted back with nothing to round, never out of range): the four products are skipped.
    if (f == Fixed::one()) return {to_grid(q.w), to_grid(q.x), to_grid(q.y), to_grid(q.z)};
    return {to_grid(q.w * f), to_grid(q.x * f), to_grid(q.y * f), to_grid(q.z * f)};
}

Quat integrated(const Quat& q, const Vec3& w, Fixed dt) {
    // a = w dt / 2 (the half angle as a vector); s = |a|^2.
    const Fixed half_dt = Fixed::from_raw(dt.raw / 2);
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
    // A slowly turning body (a ball at rest in a pile) has s^2 or s^3 below half an ulp: that
    // power rounds to exactly 0, and so does every product of it (round(0 * x) = 0), so those
    // products are not taken (times_nonzero). The same bits: Quat.IntegratedShortcutsGiveTheGeneralBits.
    const Fixed s2 = s * s, s3 = times_nonzero(s2, s);
    // cos|a| = 1 - s/2 + s^2/24 - s^3/720;  sin|a| / |a| = 1 - s/6 + s^2/120 - s^3/5040.
    static const Fixed c24 = Fixed::ratio(1, 24), c720 = Fixed::ratio(1, 720), k6 = Fixed::ratio(1, 6),
                       k120 = Fixed::ratio(1, 120), k5040 = Fixed::ratio(1, 5040);
    const Fixed c = Fixed::one() - Fixed::from_raw(s.raw / 2) + times_nonzero(s2, c24) - times_nonzero(s3, c720);
    const Fixed k = Fixed::one() - s * k6 + times_nonzero(s2, k120) - times_nonzero(s3, k5040);
    const Quat dq{c, a.x * k, a.y * k, a.z * k};
    return renormalised(dq * q);
}

Quat normalised(const Quat& q) {
    const u128 sq = length_sq_wide({q.w, q.x, q.y}) + static_cast<u128>(mul_wide(q.z.raw, q.z.raw));
    if (sq == 0) return Quat{};
    const Fixed len = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(sq)));
    return renormalised({q.w / len, q.x / len, q.y / len, q.z / len});
}

}  // namespace lockroll::sim
