// Three-component fixed-point vector. Dot products and lengths accumulate exact 128-bit
// products and round once, so |v| and v.w are correctly rounded, not the sum of three roundings.
#pragma once

#include <lockroll/sim/fixed.h>

namespace lockroll::sim {

struct Vec3 {
    Fixed x, y, z;

    friend constexpr bool operator==(const Vec3&, const Vec3&) = default;
};

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(const Vec3& a, Fixed s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 operator*(Fixed s, const Vec3& a) { return a * s; }
inline Vec3& operator+=(Vec3& a, const Vec3& b) { return a = a + b; }
inline Vec3& operator-=(Vec3& a, const Vec3& b) { return a = a - b; }

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

}  // namespace lockroll::sim
