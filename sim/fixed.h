// Q32.32 fixed-point scalar: the only number type the simulation computes with.
//
// Contract
//  - Value = raw / 2^32, raw an int64: range [-2^31, 2^31 - 2^-32], resolution 2^-32 (~2.3e-10).
//  - Every operation is defined for every input. Results that do not fit saturate to
//    Fixed::max() / Fixed::min() and bump the calling thread's overflow counter
//    (overflow_events()); a World folds that counter into its own state once per step, so
//    overflow is never undefined behaviour and never silent.
//  - Rounding: multiply, divide, square root and decimal parsing are correctly rounded to the
//    nearest representable value, ties to even. Add and subtract are exact when they fit.
//  - Division by zero saturates toward the sign of the dividend (0/0 gives 0) and counts as an
//    overflow; so does sqrt of a negative number (gives 0).
//  - No float or double anywhere: results are bit-identical on every compiler and CPU with
//    two's-complement int64 (guaranteed by C++20), whether the 128-bit intermediates come from
//    the compiler's __int128 or the portable implementation (sim/wide_int.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <lockroll/sim/wide_int.h>

namespace lockroll::sim {

// Overflow events on this thread since it started. Monotonic; callers diff it around a step.
std::uint64_t overflow_events();
void note_overflow();
// Adds `count` events at once: what a parallel step's tasks counted on other threads
// (sim/parallel_tasks.h).
void note_overflows(std::uint64_t count);

struct Fixed {
    static constexpr int kFracBits = 32;
    static constexpr std::int64_t kOne = std::int64_t{1} << kFracBits;

    std::int64_t raw = 0;

    static constexpr Fixed from_raw(std::int64_t r) { return Fixed{r}; }
    static constexpr Fixed max() { return Fixed{INT64_MAX}; }
    static constexpr Fixed min() { return Fixed{INT64_MIN}; }
    static constexpr Fixed zero() { return Fixed{0}; }
    static constexpr Fixed one() { return Fixed{kOne}; }

    // Integer to fixed; saturates (and counts) outside [-2^31, 2^31).
    static Fixed from_int(std::int64_t v);
    // num/den correctly rounded (ties to even); den == 0 saturates and counts.
    static Fixed ratio(std::int64_t num, std::int64_t den);
    // Exact decimal text ("-12.5", "3", "1e-3", "2.5E+2") to the nearest Q32.32 value, ties to
    // even. Returns nullopt for malformed text (the whole text must be the number: no spaces,
    // no hex, inf or nan), more than kMaxSignificantDigits significant digits (leading zeros do
    // not count, trailing ones do), an exponent beyond +-kMaxExponent, or a value whose rounding
    // lies outside the range (parsing is input validation: it never saturates). Every
    // to_string() output parses back exactly.
    static std::optional<Fixed> parse(std::string_view text);
    static constexpr int kMaxSignificantDigits = 64;  // any Q32.32 value needs at most 42
    static constexpr int kMaxExponent = 400;

    // Shortest-enough decimal rendering for messages and logs (exact: 32 fractional bits need at
    // most 32 decimal digits; trailing zeros are trimmed).
    std::string to_string() const;

    friend constexpr bool operator==(Fixed a, Fixed b) { return a.raw == b.raw; }
    friend constexpr auto operator<=>(Fixed a, Fixed b) { return a.raw <=> b.raw; }
};

// ---- arithmetic (inline: these are the simulation's inner loop) ----

inline Fixed saturate_i128(i128 v) {
    if (v > INT64_MAX) { note_overflow(); return Fixed::max(); }
    if (v < INT64_MIN) { note_overflow(); return Fixed::min(); }
    return Fixed::from_raw(static_cast<std::int64_t>(v));
}

// Rounds v / 2^shift to nearest, ties to even, without overflow for any v, 1 <= shift <= 126.
// A template so that tools may pass the compiler's __int128 even when sim/ computes with the
// portable i128.
template <class I>
constexpr I round_shift(I v, int shift) {
    const I q = v >> shift;                     // floor (arithmetic shift)
    const I rem = v & ((I{1} << shift) - 1);    // v - q * 2^shift, in [0, 2^shift)
    const I half = I{1} << (shift - 1);
    // Round up when rem > half, or rem == half and q is odd (ties to even).
    return q + static_cast<I>(rem + (q & 1) > half);
}

// v / 2^32 rounded to nearest, ties to even, saturated (and counted): exactly
// saturate_i128(round_shift(v, Fixed::kFracBits)), the rounding under every product and dot
// product. The common case (the result fits) is taken on v's two 64-bit halves, with the
// round-up as a flag rather than a branch on the discarded bits (which are as good as random):
// about 20 instructions where the generic i128 code compiles to 30 and a mispredicted branch.
// Anything else goes the generic way, so results and overflow counts are the same integers
// (tests/sim/fixed_test.cpp compares the two).
inline Fixed round_wide(i128 v) {
#if LOCKROLL_BUILTIN_INT128
    const auto lo = static_cast<std::uint64_t>(v);
    const auto hi = static_cast<std::uint64_t>(v >> 64);
#else
    const std::uint64_t lo = v.low(), hi = v.high();
#endif
    if (((hi + 0x80000000u) >> 32) == 0) {  // v >> 32 fits in int64: hi sign-extends its bit 31
        const std::uint64_t q = (lo >> 32) | (hi << 32);
        const std::uint64_t up = ((lo & 0xFFFFFFFFu) + (q & 1)) > 0x80000000u;
        std::int64_t r;
        if (!add_overflow(static_cast<std::int64_t>(q), static_cast<std::int64_t>(up), &r)) return Fixed::from_raw(r);
    }
    return saturate_i128(round_shift(v, Fixed::kFracBits));
}

inline Fixed operator+(Fixed a, Fixed b) {
    std::int64_t r;
    if (add_overflow(a.raw, b.raw, &r)) {
        note_overflow();
        return b.raw > 0 ? Fixed::max() : Fixed::min();
    }
    return Fixed::from_raw(r);
}
inline Fixed operator-(Fixed a, Fixed b) {
    std::int64_t r;
    if (sub_overflow(a.raw, b.raw, &r)) {
        note_overflow();
        return b.raw < 0 ? Fixed::max() : Fixed::min();
    }
    return Fixed::from_raw(r);
}
inline Fixed operator-(Fixed a) {
    if (a.raw == INT64_MIN) { note_overflow(); return Fixed::max(); }
    return Fixed::from_raw(-a.raw);
}
inline Fixed operator*(Fixed a, Fixed b) {
    return round_wide(mul_wide(a.raw, b.raw));
}
// Fixed times a plain integer (exact unless it overflows).
inline Fixed operator*(Fixed a, std::int64_t k) {
    std::int64_t r;
    if (mul_overflow(a.raw, k, &r)) {
        note_overflow();
        return ((a.raw < 0) != (k < 0)) ? Fixed::min() : Fixed::max();
    }
    return Fixed::from_raw(r);
}
Fixed operator/(Fixed a, Fixed b);

inline Fixed& operator+=(Fixed& a, Fixed b) { return a = a + b; }
inline Fixed& operator-=(Fixed& a, Fixed b) { return a = a - b; }
inline Fixed& operator*=(Fixed& a, Fixed b) { return a = a * b; }

inline Fixed abs(Fixed a) { return a.raw < 0 ? -a : a; }
inline Fixed min(Fixed a, Fixed b) { return a.raw < b.raw ? a : b; }
inline Fixed max(Fixed a, Fixed b) { return a.raw < b.raw ? b : a; }
inline Fixed clamp(Fixed v, Fixed lo, Fixed hi) { return min(max(v, lo), hi); }

// floor(sqrt(n)) for any unsigned 128-bit n (exact).
std::uint64_t isqrt_floor(u128 n);
// sqrt(n) rounded to nearest (no ties are possible for integers). The only unrepresentable
// result, 2^64 for n > (2^64 - 1)^2 + 2^64 - 1, saturates to 2^64 - 1 (not counted: callers
// pass at most 3 * 2^126).
std::uint64_t isqrt_round(u128 n);

// Square root, correctly rounded. Negative input gives 0 and counts as an overflow.
Fixed sqrt(Fixed a);
// 1 / a, correctly rounded; a == 0 saturates and counts.
Fixed reciprocal(Fixed a);

}  // namespace lockroll::sim
