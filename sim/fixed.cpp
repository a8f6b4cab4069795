#include "sim/fixed.h"

#include <algorithm>
#include <array>
#include <bit>
#include <vector>

namespace lockroll::sim {

namespace {
// Per-thread so that worlds stepping on different threads never share a counter; a World
// reads the difference around its own (single-threaded) step.
thread_local std::uint64_t t_overflow_events = 0;

int bit_length(u128 n) {
    const auto hi = static_cast<std::uint64_t>(n >> 64);
    if (hi) return 128 - std::countl_zero(hi);
    return 64 - std::countl_zero(static_cast<std::uint64_t>(n));
}

// (hi * 2^64 + lo) / d and its remainder for hi < d (the quotient fits 64 bits): one divq on
// x86-64 with __int128, the compiler's 128-bit division elsewhere, Knuth's algorithm D in the
// portable build. The same integers every way.
std::uint64_t div_128_64(std::uint64_t hi, std::uint64_t lo, std::uint64_t d, std::uint64_t& r) {
#if LOCKROLL_BUILTIN_INT128 && defined(__x86_64__)
    std::uint64_t q;
    __asm__("divq %4" : "=a"(q), "=d"(r) : "a"(lo), "d"(hi), "rm"(d));
    return q;
#elif LOCKROLL_BUILTIN_INT128
    const u128 n = (static_cast<u128>(hi) << 64) | lo;
    r = static_cast<std::uint64_t>(n % d);
    return static_cast<std::uint64_t>(n / d);
#else
    return wide_detail::div_128_64(hi, lo, d, r);
#endif
}

// |n| / |d| and |n| % |d| for d != 0. On x86-64, when the quotient fits 64 bits (every
// in-range result), one divq instruction gives exactly what the generic 128-bit division does,
// several times faster; the results are the same integers either way, so determinism holds.
// The portable path (sim/fixed.h's Int128 / UInt128) never uses assembly.
void divmod_unsigned(u128 n, u128 d, u128& q, u128& r) {
#if LOCKROLL_BUILTIN_INT128 && defined(__x86_64__)
    const auto hi = static_cast<std::uint64_t>(n >> 64);
    if ((d >> 64) == 0 && hi < static_cast<std::uint64_t>(d)) {
        std::uint64_t r64;
        q = div_128_64(hi, static_cast<std::uint64_t>(n), static_cast<std::uint64_t>(d), r64);
        r = r64;
        return;
    }
#endif
    divmod(n, d, q, r);
}

// Correctly rounded n / d (ties to even) for d != 0, saturating to int64.
Fixed divide_round(i128 n, i128 d) {
    const bool negative = (n < 0) != (d < 0);
    const u128 an = static_cast<u128>(n < 0 ? -n : n);
    const u128 ad = static_cast<u128>(d < 0 ? -d : d);
    u128 q, r;
    divmod_unsigned(an, ad, q, r);
    // Round to nearest, ties to even: compare 2|r| with |d| (no overflow: |r| < |d| <= 2^127).
    const u128 twice = r << 1;
    if (twice > ad || (twice == ad && (q & 1))) ++q;
    // |quotient| up to 2^96 here; saturate_i128 takes the sign back on.
    const i128 mag = q > (u128{1} << 100) ? static_cast<i128>(u128{1} << 100) : static_cast<i128>(q);
    return saturate_i128(negative ? -mag : mag);
}

// a / b in Fixed (raw a * 2^32 / raw b) for b != 0: exactly divide_round(mul_wide(a, 2^32), b),
// results and overflow counts, on 64-bit words. |a| * 2^32 is |a| >> 32 : |a| << 32; when the
// high word is below |b| the quotient fits 64 bits and one 128/64 division gives it, else the
// quotient is at least 2^64 and saturates (one event, like divide_round). Rounding compares the
// remainder r with |b| - r (no overflow: r < |b|). The round-up cannot wrap: the quotient is at
// most 2^63 for |b| >= 2^32 (|a| <= 2^63), and for |b| < 2^32 the test gives |a| <= |b| 2^32 - 1,
// so the quotient is at most 2^64 - 2^32 / |b| < 2^64 - 1. A rounded quotient of 2^63 fits only
// when negative.
Fixed divide_fixed(std::int64_t a, std::int64_t b) {
    const bool negative = (a < 0) != (b < 0);
    const std::uint64_t ua = a < 0 ? 0 - static_cast<std::uint64_t>(a) : static_cast<std::uint64_t>(a);
    const std::uint64_t ub = b < 0 ? 0 - static_cast<std::uint64_t>(b) : static_cast<std::uint64_t>(b);
    constexpr std::uint64_t kTwo63 = std::uint64_t{1} << 63;
    const std::uint64_t hi = ua >> 32;
    if (hi < ub) {
        std::uint64_t r;
        std::uint64_t q = div_128_64(hi, ua << 32, ub, r);
        const std::uint64_t rest = ub - r;
        q += (r > rest || (r == rest && (q & 1))) ? 1 : 0;
        if (q < kTwo63) return Fixed::from_raw(negative ? -static_cast<std::int64_t>(q) : static_cast<std::int64_t>(q));
        if (q == kTwo63 && negative) return Fixed::min();
    }
    note_overflow();
    return negative ? Fixed::min() : Fixed::max();
}
}  // namespace

std::uint64_t overflow_events() { return t_overflow_events; }
void note_overflow() { ++t_overflow_events; }
void note_overflows(std::uint64_t count) { t_overflow_events += count; }

Fixed round_wide_generic(i128 v) { return saturate_i128(round_shift(v, Fixed::kFracBits)); }

Fixed Fixed::from_int(std::int64_t v) {
    if (v >= (std::int64_t{1} << 31)) { note_overflow(); return max(); }
    if (v < -(std::int64_t{1} << 31)) { note_overflow(); return min(); }
    return from_raw(v * kOne);
}

Fixed Fixed::ratio(std::int64_t num, std::int64_t den) {
    if (den == 0) {
        note_overflow();
        return num > 0 ? max() : num < 0 ? min() : zero();
    }
    return divide_round(mul_wide(num, kOne), den);
}

Fixed operator/(Fixed a, Fixed b) {
    if (b.raw == 0) {
        note_overflow();
        return a.raw > 0 ? Fixed::max() : a.raw < 0 ? Fixed::min() : Fixed::zero();
    }
    return divide_fixed(a.raw, b.raw);
}

namespace {
// ceil(sqrt((i + 1) 2^16)) for i < 512: from the top 8 or 9 bits `top` of a radicand n with e
// bits below them, sqrt(n) < sqrt((top + 1) 2^e) <= kSqrtStart[top] 2^(e/2 - 8).
constexpr std::array<std::uint16_t, 512> kSqrtStart = [] {
    std::array<std::uint16_t, 512> t{};
    std::uint32_t r = 0;
    for (std::uint32_t i = 0; i < 512; ++i) {
        const std::uint32_t v = (i + 1) << 16;
        while (r * r < v) ++r;  // nondecreasing in i: r carries on from the last entry
        t[i] = static_cast<std::uint16_t>(r);
    }
    return t;
}();

// The first iterate of Newton's iteration for floor(sqrt(n)), len = bit_length(n) > 0, on words
// W (iterates) and N (n: std::uint64_t for isqrt_floor_64, u128 for the wider iterations) with
// a division divide(x) = floor(n / x), from a start no smaller than sqrt(n): itself no smaller
// than floor(sqrt(n)) (see isqrt_floor). Every iteration starts here, so each radicand has one
// start whatever the word it is computed in.
template <class W, class N, class Divide>
[[gnu::always_inline]] inline W isqrt_first_iterate(N n, int len, Divide divide) {
    if (len < 24) {
        // Short radicands: a power of two no smaller than sqrt(n); its first division a shift.
        const int shift = (len + 1) / 2;
        return ((W{1} << shift) + static_cast<W>(n >> shift)) >> 1;
    }
    const int e = (len - 8) & ~1;                       // even, >= 16: top has 8 or 9 bits
    const auto top = static_cast<std::uint32_t>(n >> e);  // in [128, 512)
    const W x = static_cast<W>(kSqrtStart[top]) << (e / 2 - 8);  // >= sqrt(n), at most 2^64
    return (x + divide(x)) >> 1;
}

// floor(n / x) for n < 2^124 as one 128/64 division (the caller keeps n's high word below x).
struct DivideNarrow {
    std::uint64_t hi, lo;
    std::uint64_t operator()(std::uint64_t x) const {
        std::uint64_t r;
        return div_128_64(hi, lo, x, r);
    }
};

// From an iterate y >= floor(sqrt(n)) of isqrt_floor's 64-bit iteration (n < 2^124), on to
// floor(sqrt(n)): the first iterate whose square is at most n.
std::uint64_t isqrt_narrow_from(u128 n, std::uint64_t y, const DivideNarrow& divide) {
    while (mul_wide_unsigned(y, y) > n) y = (y + divide(y)) >> 1;
    return y;
}

// floor(sqrt(n)) for 0 < n < 2^64, len = bit_length(n): isqrt_floor's iteration (the same
// start, the same iterates) with 64-bit quotients. Inline in isqrt_floor and isqrt_round.
[[gnu::always_inline]] inline std::uint64_t isqrt_floor_64(std::uint64_t n, int len) {
    std::uint64_t y = isqrt_first_iterate<std::uint64_t>(n, len, [n](std::uint64_t x) { return n / x; });
    // The start is at most 2^32 (kSqrtStart[255] 2^20 for a 64-bit n), so every iterate after
    // it is at most (2^32 + sqrt(n)) / 2 < 2^32: its square fits a 64-bit word.
    while (y * y > n) y = (y + n / y) >> 1;
    return y;
}

// isqrt_floor for n >= 2^64 (out of line: its registers would cost the 64-bit path a save and
// restore).
[[gnu::noinline]] std::uint64_t isqrt_floor_wide(u128 n) {
    const int len = bit_length(n);
    if (len <= 124) {
        const DivideNarrow divide{static_cast<std::uint64_t>(n >> 64), static_cast<std::uint64_t>(n)};
        return isqrt_narrow_from(n, isqrt_first_iterate<std::uint64_t>(n, len, divide), divide);
    }
    // Wider: an iterate may be 2^64, whose square does not fit in 128 bits; stop instead where
    // the next iterate is no smaller.
    const auto divide = [&n](const u128& x) {
        u128 q, r;
        divmod_unsigned(n, x, q, r);
        return q;
    };
    u128 x = isqrt_first_iterate<u128>(n, len, divide);
    u128 y = (x + divide(x)) >> 1;
    while (y < x) {
        x = y;
        y = (x + divide(x)) >> 1;
    }
    return static_cast<std::uint64_t>(x);
}

// sqrt(n) rounded to nearest from r = floor(sqrt(n)).
std::uint64_t round_root(u128 n, std::uint64_t r) {
    // sqrt(n) > r + 1/2  <=>  n > r^2 + r  (n is an integer, so no tie can occur).
    const u128 r2 = mul_wide_unsigned(r, r);
    // r == 2^64 - 1 can only round up to 2^64, which does not fit: saturate instead of wrapping.
    return (n - r2 > r && r != UINT64_MAX) ? r + 1 : r;
}

// isqrt_round for n = 0 or n >= 2^64, out of line (a tail call: the 64-bit path saves no
// registers for it).
[[gnu::noinline]] std::uint64_t isqrt_round_wide(u128 n) { return round_root(n, isqrt_floor(n)); }
}  // namespace

std::uint64_t isqrt_floor(u128 n) {
    // Newton's iteration x <- floor((x + floor(n / x)) / 2) from any x >= floor(sqrt(n))
    // decreases strictly while x > floor(sqrt(n)) and never below it, and stops there (the
    // next iterate is not smaller): the result is the same integer whatever the start, which
    // only sets how many steps it takes. A start from a power of two (up to a factor sqrt(2)
    // high) took about 6 divisions for a 50-bit radicand; from the table (within 2^-7) it
    // takes about 3 (docs/performance.md, "Rigid solver, fourth pass").
    // From any positive start x (even one below sqrt(n)) the first iterate is already at least
    // floor(sqrt(n)): (x + n / x) / 2 >= sqrt(n) (the arithmetic-geometric mean), and flooring
    // n / x and the halving loses only fractions, floor((x + floor(n / x)) / 2) =
    // floor((x + n / x) / 2) >= floor(sqrt(n)).
    // Since every iterate after the first is >= floor(sqrt(n)), it is floor(sqrt(n)) exactly
    // when its square is at most n: one product tells where the iteration stops, instead of
    // a further division that finds the next iterate no smaller (issue 19, "Sliding
    // friction's square root" in docs/performance.md).
    // Each step divides by x < 2^64 with a quotient n / x <= sqrt(n) < 2^64, one 128/64
    // division; the iterates are the same integers however the quotients are found.
    // Below 2^124 every iterate is a 64-bit word: sqrt(n) < 2^62, the start is at most
    // sqrt(n) (1 + 2^-7) + 2^(e/2 - 8) < 2^62.1, the quotients n / x <= n / floor(sqrt(n)) <
    // floor(sqrt(n)) + 3 < 2^63 (so n's high word is below x, as the 128/64 division needs), and
    // x + n / x < 2^64 (and x^2 < 2^126): the same integers as the 128-bit iteration for wider
    // n, with no 128-bit adds, shifts and compares around each division.
    // Below 2^64 (nearly all of the contact solver's radicands) the same iteration runs on n's
    // low word alone: sqrt(n) < 2^32, the start is below 2^32.1, each quotient is one 64-bit
    // division and the iterates' sum stays below 2^64; the wider iterations are out of line
    // (isqrt_floor_wide), so this one saves and restores no registers (issue 19).
    const auto lo = static_cast<std::uint64_t>(n);
    if ((n >> 64) == 0) return lo == 0 ? 0 : isqrt_floor_64(lo, std::bit_width(lo));
    return isqrt_floor_wide(n);
}

std::uint64_t isqrt_round(u128 n) {
    const auto lo = static_cast<std::uint64_t>(n);
    if ((n >> 64) == 0 && lo != 0) {
        // r < 2^32: r^2 + r < 2^64, the test in 64-bit words.
        const std::uint64_t r = isqrt_floor_64(lo, std::bit_width(lo));
        return lo - r * r > r ? r + 1 : r;
    }
    return isqrt_round_wide(n);
}

Fixed sqrt(Fixed a) {
    if (a.raw < 0) { note_overflow(); return Fixed::zero(); }
    // sqrt(raw / 2^32) * 2^32 = sqrt(raw * 2^32); at most 2^47.5, always fits.
    return sqrt_wide(static_cast<u128>(a.raw) << 32);
}

Fixed reciprocal(Fixed a) { return Fixed::one() / a; }

namespace {
// Unsigned big integers in base-2^32 limbs, least significant first, no leading zero limbs:
// just what exact decimal parsing needs.
using Big = std::vector<std::uint32_t>;

void mul_add_small(Big& b, std::uint32_t m, std::uint32_t add) {
    std::uint64_t carry = add;
    for (auto& limb : b) {
        const std::uint64_t t = std::uint64_t{limb} * m + carry;
        limb = static_cast<std::uint32_t>(t);
        carry = t >> 32;
    }
    if (carry) b.push_back(static_cast<std::uint32_t>(carry));
}

int compare(const Big& a, const Big& b) {
    if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
    for (std::size_t k = a.size(); k-- > 0;)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

void subtract(Big& a, const Big& b) {  // a -= b, requires a >= b
    std::int64_t borrow = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        const std::int64_t t = std::int64_t{a[k]} - borrow - (k < b.size() ? std::int64_t{b[k]} : 0);
        borrow = t < 0;
        a[k] = static_cast<std::uint32_t>(t + (borrow << 32));
    }
    while (!a.empty() && a.back() == 0) a.pop_back();
}

void shift_left_1(Big& b) {
    std::uint32_t carry = 0;
    for (auto& limb : b) {
        const std::uint32_t next = limb >> 31;
        limb = (limb << 1) | carry;
        carry = next;
    }
    if (carry) b.push_back(carry);
}
}  // namespace

std::optional<Fixed> Fixed::parse(std::string_view s) {
    std::size_t i = 0;
    bool negative = false;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) negative = s[i++] == '-';
    // Collect the significant digits into an exact integer mantissa; `scale` counts decimal
    // places. The mantissa is a big integer because to_string() writes up to 42 digits
    // (10 integer + 32 fraction) and those must parse back exactly.
    Big mantissa;
    int digits = 0, scale = 0;
    bool any_digit = false, seen_point = false;
    for (; i < s.size(); ++i) {
        const char c = s[i];
        if (c == '.') {
            if (seen_point) return std::nullopt;
            seen_point = true;
            continue;
        }
        if (c < '0' || c > '9') break;
        any_digit = true;
        // Only leading zeros can make scale large; capping it keeps the value (zero) and the int.
        if (seen_point && scale < 100000) ++scale;
        if (mantissa.empty() && c == '0') continue;  // leading zeros are not significant
        if (++digits > kMaxSignificantDigits) return std::nullopt;
        mul_add_small(mantissa, 10, static_cast<std::uint32_t>(c - '0'));
    }
    if (!any_digit) return std::nullopt;
    int exponent = 0;
    if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
        ++i;
        bool eneg = false;
        if (i < s.size() && (s[i] == '+' || s[i] == '-')) eneg = s[i++] == '-';
        if (i >= s.size()) return std::nullopt;
        for (; i < s.size(); ++i) {
            if (s[i] < '0' || s[i] > '9') return std::nullopt;
            exponent = exponent * 10 + (s[i] - '0');
            if (exponent > kMaxExponent) return std::nullopt;
        }
        if (eneg) exponent = -exponent;
    }
    if (i != s.size()) return std::nullopt;
    if (mantissa.empty()) return zero();

    // value = mantissa * 10^(exponent - scale). Bring it to an exact integer ratio num/den and
    // round num * 2^32 / den once. Magnitudes far outside the range are decided early.
    const int e10 = exponent - scale;
    if (e10 > 10) return std::nullopt;  // >= 1e11 > 2^31 for any non-zero mantissa
    // mantissa < 10^64, so e10 <= -75 means value < 1e-11, under half an ulp (1.16e-10).
    if (e10 <= -75) return zero();

    Big num = mantissa;
    num.insert(num.begin(), 0u);  // * 2^32
    for (int k = 0; k < e10; ++k) mul_add_small(num, 10, 0);
    Big den{1u};
    for (int k = 0; k < -e10; ++k) mul_add_small(den, 10, 0);

    // Long division num / den, bit by bit: the quotient is below 2^64 for accepted values.
    const int num_bits = static_cast<int>(num.size()) * 32;
    Big rem;
    u128 q = 0;
    for (int bit = num_bits - 1; bit >= 0; --bit) {
        shift_left_1(rem);
        if ((num[static_cast<std::size_t>(bit / 32)] >> (bit % 32)) & 1u) {
            if (rem.empty()) rem.push_back(1u); else rem[0] |= 1u;
        }
        q <<= 1;
        if (compare(rem, den) >= 0) { subtract(rem, den); q |= 1; }
        if (q >> 70) return std::nullopt;  // far out of range
    }
    // Round to nearest, ties to even: compare 2*rem with den.
    shift_left_1(rem);
    const int c = compare(rem, den);
    if (c > 0 || (c == 0 && (q & 1))) ++q;
    const u128 limit = negative ? (u128{1} << 63) : (u128{1} << 63) - 1;
    if (q > limit) return std::nullopt;
    if (negative) return from_raw(q == (u128{1} << 63) ? INT64_MIN : -static_cast<std::int64_t>(q));
    return from_raw(static_cast<std::int64_t>(q));
}

std::string Fixed::to_string() const {
    std::string out;
    // |raw| <= 2^63 fits uint64; the fraction times 10 stays below 2^36.
    const std::uint64_t mag = raw < 0 ? 0 - static_cast<std::uint64_t>(raw) : static_cast<std::uint64_t>(raw);
    if (raw < 0) out.push_back('-');
    out += std::to_string(mag >> 32);
    std::uint64_t frac = mag & 0xFFFFFFFFu;
    if (frac) {
        out.push_back('.');
        // Each step multiplies the fraction by 10 and emits the integer digit: exact.
        while (frac) {
            frac *= 10;
            out.push_back(static_cast<char>('0' + static_cast<int>(frac >> 32)));
            frac &= 0xFFFFFFFFu;
        }
    }
    return out;
}

}  // namespace lockroll::sim
