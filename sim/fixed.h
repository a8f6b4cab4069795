// Q32.32 fixed-point scalar: the only number type the simulation computes with, and the
// integer layer under it (128-bit integers, overflow-checked 64-bit arithmetic), which is here
// because Fixed's arithmetic is inline over it: a Q32.32 product needs a 128-bit intermediate,
// and inline is what keeps the step fast.
//
// Contract (Fixed)
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
//    the compiler's __int128 or the portable implementation (below).
//
// Contract (the integer layer)
//  - i128 / u128 are two's-complement 128-bit integers with exactly the semantics of GCC/Clang's
//    __int128 where that is defined: add, subtract, multiply and left shift wrap modulo 2^128,
//    division truncates toward zero, >> on i128 is arithmetic. Division by zero and shift counts
//    outside [0, 127] are not defined (as for the builtin). Conversions to narrower integers keep
//    the low bits; conversions from integers sign- or zero-extend.
//  - mul_wide / mul_wide_unsigned give the exact 64 x 64 -> 128-bit product; divmod the 128-bit
//    quotient and remainder; add_overflow / sub_overflow / mul_overflow behave like GCC's
//    __builtin_*_overflow (wrapped result stored, true when the true result does not fit).
//  - Two implementations, bit-identical by construction and by test (tests/sim/wide_int_test.cpp
//    checks every operation against __int128 on millions of inputs):
//      builtin   the compiler's __int128 and __builtin_*_overflow: GCC and Clang on 64-bit
//                targets (x86-64, aarch64, s390x) and wasm32.
//      portable  UInt128 / Int128 below, plain standard C++20 with no intrinsics and no inline
//                assembly: the product from four 32 x 32 -> 64-bit partial products, the
//                division from 32-bit digits (Knuth's algorithm D, two digits per 128/64 step).
//                Chosen automatically where __int128 is missing (MSVC, 32-bit GCC such as
//                i386 and armhf); defining LOCKROLL_PORTABLE_MATH=1 (CMake option
//                LOCKROLL_PORTABLE_MATH=ON) forces it, so 64-bit GCC/Clang test it too.
//    LOCKROLL_BUILTIN_INT128 says which one is in use (1 builtin, 0 portable). The definition must
//    be the same in every translation unit of a program (CMake puts it on lockroll::sim's public
//    interface).
//  - UInt128 and Int128 are always defined (the tests compare them with __int128 in every build);
//    only the i128 / u128 aliases switch.
#pragma once

#include <bit>
#include <compare>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>

#if defined(LOCKROLL_PORTABLE_MATH) && LOCKROLL_PORTABLE_MATH
#define LOCKROLL_BUILTIN_INT128 0
#elif defined(__SIZEOF_INT128__)
#define LOCKROLL_BUILTIN_INT128 1
#else
#define LOCKROLL_BUILTIN_INT128 0
#endif

namespace lockroll::sim {

// ---- the integer layer: 128-bit integers and overflow-checked 64-bit arithmetic ----

namespace wide_detail {
inline constexpr std::uint64_t kLow32 = 0xFFFFFFFFu;

// Exact 64 x 64 -> 128-bit unsigned product from four 32 x 32 -> 64-bit products.
constexpr void mul_64x64(std::uint64_t a, std::uint64_t b, std::uint64_t& hi, std::uint64_t& lo) {
    const std::uint64_t a0 = a & kLow32, a1 = a >> 32, b0 = b & kLow32, b1 = b >> 32;
    const std::uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    const std::uint64_t mid = (p00 >> 32) + (p01 & kLow32) + (p10 & kLow32);  // < 3 * 2^32
    lo = (mid << 32) | (p00 & kLow32);
    hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);  // the product is < 2^128: no carry out
}

// (hi * 2^64 + lo) / d for hi < d (so the quotient fits 64 bits); the remainder goes to r.
// Knuth's algorithm D on 32-bit digits (Hacker's Delight, divlu): normalize d so its top bit
// is set, then find the two 32-bit quotient digits, each estimated from the top digits and
// corrected at most twice.
constexpr std::uint64_t div_128_64(std::uint64_t hi, std::uint64_t lo, std::uint64_t d, std::uint64_t& r) {
    constexpr std::uint64_t b = std::uint64_t{1} << 32;
    const int s = std::countl_zero(d);  // 0..63, d != 0
    d <<= s;
    const std::uint64_t dn1 = d >> 32, dn0 = d & kLow32;
    const std::uint64_t un32 = (hi << s) | (s == 0 ? 0 : lo >> (64 - s));
    const std::uint64_t un10 = lo << s;
    const std::uint64_t un1 = un10 >> 32, un0 = un10 & kLow32;

    std::uint64_t q1 = un32 / dn1, rhat = un32 - q1 * dn1;
    while (q1 >= b || q1 * dn0 > b * rhat + un1) {
        --q1;
        rhat += dn1;
        if (rhat >= b) break;
    }
    const std::uint64_t un21 = un32 * b + un1 - q1 * d;  // modulo 2^64: the true value is < d
    std::uint64_t q0 = un21 / dn1;
    rhat = un21 - q0 * dn1;
    while (q0 >= b || q0 * dn0 > b * rhat + un0) {
        --q0;
        rhat += dn1;
        if (rhat >= b) break;
    }
    r = (un21 * b + un0 - q0 * d) >> s;
    return q1 * b + q0;
}

// The compound assignments and increments of a 128-bit integer T, each the assignment of T's
// own binary operator, written once for UInt128 and Int128 (a CRTP base: T derives from
// CompoundOps<T>; hidden friends, found through T by argument-dependent lookup; empty, so
// T's layout is its two words alone).
template <class T>
struct CompoundOps {
    // Nothing to compare: what lets T's defaulted == compare its words alone.
    friend constexpr bool operator==(const CompoundOps&, const CompoundOps&) = default;
    friend constexpr T& operator+=(T& a, const T& b) { return a = a + b; }
    friend constexpr T& operator-=(T& a, const T& b) { return a = a - b; }
    friend constexpr T& operator*=(T& a, const T& b) { return a = a * b; }
    friend constexpr T& operator/=(T& a, const T& b) { return a = a / b; }
    friend constexpr T& operator%=(T& a, const T& b) { return a = a % b; }
    friend constexpr T& operator&=(T& a, const T& b) { return a = a & b; }
    friend constexpr T& operator|=(T& a, const T& b) { return a = a | b; }
    friend constexpr T& operator^=(T& a, const T& b) { return a = a ^ b; }
    friend constexpr T& operator<<=(T& a, int s) { return a = a << s; }
    friend constexpr T& operator>>=(T& a, int s) { return a = a >> s; }
    friend constexpr T& operator++(T& a) { return a += 1; }
    friend constexpr T& operator--(T& a) { return a -= 1; }
};
}  // namespace wide_detail

class Int128;

// Unsigned 128-bit integer in two 64-bit words, portable standard C++20.
class UInt128 : public wide_detail::CompoundOps<UInt128> {
public:
    constexpr UInt128() = default;
    // Implicit from every integer type, like the builtin: signed values are sign-extended.
    template <class T>
        requires std::is_integral_v<T>
    constexpr UInt128(T v) : lo_(static_cast<std::uint64_t>(v)) {
        if constexpr (std::is_signed_v<T>) hi_ = v < 0 ? ~std::uint64_t{0} : 0;
    }
    explicit constexpr UInt128(const Int128& v);
    static constexpr UInt128 from_words(std::uint64_t hi, std::uint64_t lo) {
        UInt128 r;
        r.hi_ = hi;
        r.lo_ = lo;
        return r;
    }
    constexpr std::uint64_t high() const { return hi_; }
    constexpr std::uint64_t low() const { return lo_; }

    // To a narrower integer: the low bits, like a cast of the builtin.
    template <class T>
        requires std::is_integral_v<T>
    explicit constexpr operator T() const { return static_cast<T>(lo_); }
    explicit constexpr operator bool() const { return (hi_ | lo_) != 0; }

#if defined(__SIZEOF_INT128__)
    // Interoperation with the builtin where the compiler has one (tests, tools); the arithmetic
    // never goes through it.
    constexpr UInt128(unsigned __int128 v) : hi_(static_cast<std::uint64_t>(v >> 64)), lo_(static_cast<std::uint64_t>(v)) {}
    constexpr UInt128(__int128 v) : UInt128(static_cast<unsigned __int128>(v)) {}
    explicit constexpr operator unsigned __int128() const { return (static_cast<unsigned __int128>(hi_) << 64) | lo_; }
    explicit constexpr operator __int128() const { return static_cast<__int128>(static_cast<unsigned __int128>(*this)); }
#endif

    friend constexpr bool operator==(const UInt128&, const UInt128&) = default;
    friend constexpr std::strong_ordering operator<=>(const UInt128& a, const UInt128& b) {
        if (a.hi_ != b.hi_) return a.hi_ <=> b.hi_;
        return a.lo_ <=> b.lo_;
    }

    friend constexpr UInt128 operator+(const UInt128& a, const UInt128& b) {
        const std::uint64_t lo = a.lo_ + b.lo_;
        return from_words(a.hi_ + b.hi_ + (lo < a.lo_ ? 1 : 0), lo);
    }
    friend constexpr UInt128 operator-(const UInt128& a, const UInt128& b) {
        return from_words(a.hi_ - b.hi_ - (a.lo_ < b.lo_ ? 1 : 0), a.lo_ - b.lo_);
    }
    friend constexpr UInt128 operator-(const UInt128& a) { return UInt128{} - a; }
    // Low 128 bits of the product: the full low-word product plus the cross terms' low words.
    friend constexpr UInt128 operator*(const UInt128& a, const UInt128& b) {
        std::uint64_t hi = 0, lo = 0;
        wide_detail::mul_64x64(a.lo_, b.lo_, hi, lo);
        return from_words(hi + a.lo_ * b.hi_ + a.hi_ * b.lo_, lo);
    }
    friend constexpr UInt128 operator/(const UInt128& a, const UInt128& b) {
        UInt128 q, r;
        divmod(a, b, q, r);
        return q;
    }
    friend constexpr UInt128 operator%(const UInt128& a, const UInt128& b) {
        UInt128 q, r;
        divmod(a, b, q, r);
        return r;
    }
    friend constexpr UInt128 operator&(const UInt128& a, const UInt128& b) { return from_words(a.hi_ & b.hi_, a.lo_ & b.lo_); }
    friend constexpr UInt128 operator|(const UInt128& a, const UInt128& b) { return from_words(a.hi_ | b.hi_, a.lo_ | b.lo_); }
    friend constexpr UInt128 operator^(const UInt128& a, const UInt128& b) { return from_words(a.hi_ ^ b.hi_, a.lo_ ^ b.lo_); }
    friend constexpr UInt128 operator~(const UInt128& a) { return from_words(~a.hi_, ~a.lo_); }
    friend constexpr UInt128 operator<<(const UInt128& a, int s) {
        if (s == 0) return a;
        if (s >= 64) return from_words(a.lo_ << (s - 64), 0);
        return from_words((a.hi_ << s) | (a.lo_ >> (64 - s)), a.lo_ << s);
    }
    friend constexpr UInt128 operator>>(const UInt128& a, int s) {
        if (s == 0) return a;
        if (s >= 64) return from_words(0, a.hi_ >> (s - 64));
        return from_words(a.hi_ >> s, (a.lo_ >> s) | (a.hi_ << (64 - s)));
    }

    // n / d and n % d (d != 0). A 64-bit divisor takes one or two 128/64 steps; a wider one
    // has a quotient below 2^64, estimated from the divisor's top 64 bits and corrected once.
    friend constexpr void divmod(const UInt128& n, const UInt128& d, UInt128& q, UInt128& r) {
        if (d.hi_ == 0) {
            std::uint64_t rem = 0;
            if (n.hi_ < d.lo_) {
                q = from_words(0, wide_detail::div_128_64(n.hi_, n.lo_, d.lo_, rem));
            } else {
                const std::uint64_t qhi = n.hi_ / d.lo_;
                q = from_words(qhi, wide_detail::div_128_64(n.hi_ - qhi * d.lo_, n.lo_, d.lo_, rem));
            }
            r = from_words(0, rem);
            return;
        }
        // Hacker's Delight, divdu: shift both so the divisor's top bit is bit 63 of a 64-bit
        // word, divide the shifted dividend by it (quotient fits: n >> 1 < 2^127), then the
        // estimate is the true quotient or one too large.
        const int s = std::countl_zero(d.hi_);  // 0..63
        const UInt128 dn = d << s;
        const UInt128 n1 = n >> 1;
        std::uint64_t unused = 0;
        std::uint64_t q0 = wide_detail::div_128_64(n1.hi_, n1.lo_, dn.hi_, unused) >> (63 - s);
        if (q0 != 0) --q0;
        UInt128 rem = n - UInt128(q0) * d;
        if (rem >= d) {
            ++q0;
            rem -= d;
        }
        q = from_words(0, q0);
        r = rem;
    }

private:
    std::uint64_t hi_ = 0;
    std::uint64_t lo_ = 0;
};

// Signed 128-bit integer (two's complement) over the same two words.
class Int128 : public wide_detail::CompoundOps<Int128> {
public:
    constexpr Int128() = default;
    template <class T>
        requires std::is_integral_v<T>
    constexpr Int128(T v) : bits_(v) {}
    explicit constexpr Int128(const UInt128& v) : bits_(v) {}
    static constexpr Int128 from_words(std::uint64_t hi, std::uint64_t lo) { return Int128(UInt128::from_words(hi, lo)); }
    constexpr std::uint64_t high() const { return bits_.high(); }
    constexpr std::uint64_t low() const { return bits_.low(); }
    constexpr bool negative() const { return (bits_.high() >> 63) != 0; }

    template <class T>
        requires std::is_integral_v<T>
    explicit constexpr operator T() const { return static_cast<T>(bits_.low()); }
    explicit constexpr operator bool() const { return static_cast<bool>(bits_); }

#if defined(__SIZEOF_INT128__)
    constexpr Int128(__int128 v) : bits_(v) {}
    constexpr Int128(unsigned __int128 v) : bits_(v) {}
    explicit constexpr operator __int128() const { return static_cast<__int128>(bits_); }
    explicit constexpr operator unsigned __int128() const { return static_cast<unsigned __int128>(bits_); }
#endif

    friend constexpr bool operator==(const Int128&, const Int128&) = default;
    friend constexpr std::strong_ordering operator<=>(const Int128& a, const Int128& b) {
        const auto ah = static_cast<std::int64_t>(a.high()), bh = static_cast<std::int64_t>(b.high());
        if (ah != bh) return ah <=> bh;
        return a.low() <=> b.low();
    }

    friend constexpr Int128 operator+(const Int128& a, const Int128& b) { return Int128(a.bits_ + b.bits_); }
    friend constexpr Int128 operator-(const Int128& a, const Int128& b) { return Int128(a.bits_ - b.bits_); }
    friend constexpr Int128 operator-(const Int128& a) { return Int128(-a.bits_); }
    friend constexpr Int128 operator*(const Int128& a, const Int128& b) { return Int128(a.bits_ * b.bits_); }
    // Truncating division: divide the magnitudes, then the quotient takes the sign of a ^ b and
    // the remainder the sign of a.
    friend constexpr Int128 operator/(const Int128& a, const Int128& b) {
        const UInt128 q = a.magnitude() / b.magnitude();
        return Int128(a.negative() != b.negative() ? -q : q);
    }
    friend constexpr Int128 operator%(const Int128& a, const Int128& b) {
        const UInt128 r = a.magnitude() % b.magnitude();
        return Int128(a.negative() ? -r : r);
    }
    friend constexpr Int128 operator&(const Int128& a, const Int128& b) { return Int128(a.bits_ & b.bits_); }
    friend constexpr Int128 operator|(const Int128& a, const Int128& b) { return Int128(a.bits_ | b.bits_); }
    friend constexpr Int128 operator^(const Int128& a, const Int128& b) { return Int128(a.bits_ ^ b.bits_); }
    friend constexpr Int128 operator~(const Int128& a) { return Int128(~a.bits_); }
    friend constexpr Int128 operator<<(const Int128& a, int s) { return Int128(a.bits_ << s); }
    // Arithmetic shift: the vacated high bits copy the sign.
    friend constexpr Int128 operator>>(const Int128& a, int s) {
        if (s == 0) return a;
        const std::uint64_t fill = a.negative() ? ~std::uint64_t{0} : 0;
        const std::uint64_t hi = a.high(), lo = a.low();
        if (s >= 64) return from_words(fill, s == 64 ? hi : (hi >> (s - 64)) | (fill << (128 - s)));
        return from_words((hi >> s) | (fill << (64 - s)), (lo >> s) | (hi << (64 - s)));
    }

private:
    constexpr UInt128 magnitude() const { return negative() ? -bits_ : bits_; }
    UInt128 bits_;
};

constexpr UInt128::UInt128(const Int128& v) : UInt128(from_words(v.high(), v.low())) {}

#if LOCKROLL_BUILTIN_INT128
using i128 = __int128;
using u128 = unsigned __int128;

inline i128 mul_wide(std::int64_t a, std::int64_t b) { return static_cast<i128>(a) * b; }
inline u128 mul_wide_unsigned(std::uint64_t a, std::uint64_t b) { return static_cast<u128>(a) * b; }
inline void divmod(u128 n, u128 d, u128& q, u128& r) {
    q = n / d;
    r = n % d;
}
inline bool add_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) { return __builtin_add_overflow(a, b, r); }
inline bool sub_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) { return __builtin_sub_overflow(a, b, r); }
inline bool mul_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) { return __builtin_mul_overflow(a, b, r); }
inline bool add_overflow(i128 a, i128 b, i128* r) { return __builtin_add_overflow(a, b, r); }
#else
using i128 = Int128;
using u128 = UInt128;

// Signed product from the unsigned one: reading a negative operand x as x + 2^64 adds the other
// operand times 2^64, which the high word takes back off.
inline i128 mul_wide(std::int64_t a, std::int64_t b) {
    std::uint64_t hi = 0, lo = 0;
    wide_detail::mul_64x64(static_cast<std::uint64_t>(a), static_cast<std::uint64_t>(b), hi, lo);
    if (a < 0) hi -= static_cast<std::uint64_t>(b);
    if (b < 0) hi -= static_cast<std::uint64_t>(a);
    return Int128::from_words(hi, lo);
}
inline u128 mul_wide_unsigned(std::uint64_t a, std::uint64_t b) {
    std::uint64_t hi = 0, lo = 0;
    wide_detail::mul_64x64(a, b, hi, lo);
    return UInt128::from_words(hi, lo);
}
// Overflow happens exactly when both operands have a sign the result does not share (add), or
// the operands differ in sign and the result's sign is not a's (subtract).
inline bool add_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) {
    *r = static_cast<std::int64_t>(static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(b));
    return ((a ^ *r) & (b ^ *r)) < 0;
}
inline bool sub_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) {
    *r = static_cast<std::int64_t>(static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b));
    return ((a ^ b) & (a ^ *r)) < 0;
}
// The product fits when its high word is the sign extension of its low word.
inline bool mul_overflow(std::int64_t a, std::int64_t b, std::int64_t* r) {
    const i128 p = mul_wide(a, b);
    *r = static_cast<std::int64_t>(p.low());
    return p.high() != static_cast<std::uint64_t>(*r >> 63);
}
inline bool add_overflow(i128 a, i128 b, i128* r) {
    *r = a + b;
    return ((a ^ *r) & (b ^ *r)).negative();
}
#endif

// ---- Fixed ----

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
// product. The common case (the result fits) is taken on v's two 64-bit halves: first add the
// bias 2^31 - 1 + (bit 32 of v), then the result is the biased value's floor >> 32, because
//   floor((v + 2^31 - 1 + odd) / 2^32) = q + (rem + odd > 2^31)
// with q = floor(v / 2^32), rem = v mod 2^32, odd = q & 1 (round half to even). Rounding before
// the range test means the test sees the rounded result, so no add-with-overflow after it (a
// value just below INT64_MIN that rounds back into range, or INT64_MAX + 1/2 that rounds out,
// is decided by the same test). The biased value fits int64 after >> 32 exactly when its high
// word is the sign extension of its bit 31. The add is done on unsigned words (it wraps only
// for v within 2^31 of the i128 maximum, whose high word then fails the test). About 10
// instructions, no data-dependent branch but the range test (never taken in a sane step).
// Anything else goes the generic way, so results and overflow counts are the same integers
// (tests/sim/fixed_test.cpp compares the two). The generic way is out of line (fixed.cpp): the
// inline part stays small, so gcc's per-file inlining budget (inline-unit-growth) reaches every
// hot caller (with it inline, sim/rigid_solver.cpp ran out of budget and called round_wide out of
// line from the solver's inner loop).
Fixed round_wide_generic(i128 v);  // saturate_i128(round_shift(v, Fixed::kFracBits))
inline Fixed round_wide(i128 v) {
#if LOCKROLL_BUILTIN_INT128
    const auto lo = static_cast<std::uint64_t>(v);
    const auto hi = static_cast<std::uint64_t>(static_cast<u128>(v) >> 64);
#else
    const std::uint64_t lo = v.low(), hi = v.high();
#endif
    const std::uint64_t lo_biased = lo + (0x7FFFFFFFu + ((lo >> 32) & 1));
    const std::uint64_t hi_biased = hi + (lo_biased < lo ? 1 : 0);
    if (static_cast<std::int64_t>(hi_biased) == static_cast<std::int32_t>(hi_biased))
        return Fixed::from_raw(static_cast<std::int64_t>((lo_biased >> 32) | (hi_biased << 32)));
    return round_wide_generic(v);
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
// sqrt(w) for w a Q64.64 value (an exact square or sum of squares of Fixed values, e.g.
// length_sq_wide), correctly rounded, as Fixed: isqrt_round(w)'s raw bits. In range for
// w <= 2^126 - 2^63 (roots up to Fixed::max(), just below 2^31). Above it the root's raw value
// wraps modulo 2^64 to a negative Fixed, neither saturated nor counted (unlike length() in
// sim/vec3.h): callers either keep w in range or, like rigid_detail::clamp_to_cone_general,
// need only that the result of a non-zero w is non-zero, which holds for every w.
inline Fixed sqrt_wide(u128 w) { return Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(w))); }

// Square root, correctly rounded. Negative input gives 0 and counts as an overflow.
Fixed sqrt(Fixed a);
// 1 / a, correctly rounded; a == 0 saturates and counts.
Fixed reciprocal(Fixed a);

}  // namespace lockroll::sim
