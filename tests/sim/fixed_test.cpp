// Accuracy and edge cases of the Q32.32 scalar (sim/fixed.h).
//
// Every operation the contract calls correctly rounded (mul, div, reciprocal, ratio, sqrt,
// parse) is checked on 1,000,000 seeded random inputs spread over magnitudes plus the edge
// values, against the EXACT rational result (integer references, see accuracy.h for why not
// long double), and the measured max / mean error in ulps and the worst input are printed
// ("[accuracy] ..." lines on stdout, and gtest properties). Saturation and the overflow counter
// are checked on every case, not only on the edge ones.
#include "sim/fixed.h"

#include <gtest/gtest.h>

#include <array>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/sim/accuracy.h"

namespace lockroll::sim {
namespace {

using namespace accuracy;
using accuracy::i128;  // the builtin references, not sim's (possibly portable) i128
using accuracy::u128;

constexpr i128 kUlpsPerOne = i128{1} << 32;

// Values where something changes: zero, one ulp, one, a half, the ends of the range.
const std::vector<std::int64_t>& edge_values() {
    static const std::vector<std::int64_t> v = [] {
        std::vector<std::int64_t> out;
        const std::int64_t base[] = {0,
                                     1,
                                     2,
                                     3,
                                     (std::int64_t{1} << 31) - 1,
                                     std::int64_t{1} << 31,  // 0.5
                                     (std::int64_t{1} << 31) + 1,
                                     std::int64_t{3} << 31,  // 1.5
                                     Fixed::kOne - 1,
                                     Fixed::kOne,
                                     Fixed::kOne + 1,
                                     std::int64_t{1} << 47,
                                     std::int64_t{1} << 48,
                                     std::int64_t{1} << 62,
                                     INT64_MAX - 1,
                                     INT64_MAX};
        for (auto b : base) {
            out.push_back(b);
            if (b != 0) out.push_back(-b);
        }
        out.push_back(INT64_MIN);
        return out;
    }();
    return v;
}

// ---------------------------------------------------------------- multiplication

// a * b is exactly (a.raw * b.raw) / 2^32 ulps.
bool check_mul(Stats& st, std::int64_t a, std::int64_t b) {
    const auto before = overflow_events();
    const Fixed r = Fixed::from_raw(a) * Fixed::from_raw(b);
    const auto events = overflow_events() - before;
    return check_rounded(st, static_cast<i128>(a) * b, kUlpsPerOne, r.raw, events,
                         [&] { return describe(a) + " * " + describe(b); });
}

TEST(FixedMul, CorrectlyRoundedOnAMillionRandomInputsAndAllEdgePairs) {
    Stats st("mul");
    for (auto a : edge_values())
        for (auto b : edge_values()) ASSERT_TRUE(check_mul(st, a, b));
    std::mt19937_64 g(kSeed);
    for (int i = 0; i < kRandomCases; ++i) ASSERT_TRUE(check_mul(st, random_raw(g), random_raw(g)));
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_GT(st.saturated, 0) << "the random spread should reach saturation";
}

// round_wide's fast path (two 64-bit halves) against the generic i128 rounding it stands for:
// the same result and the same overflow count for every kind of input, the edges of the int64
// range (where rounding up brings a value just below INT64_MIN back into range) included.
bool round_wide_matches_generic(i128 v) {
    const auto before = overflow_events();
    const Fixed fast = round_wide(v);
    const auto fast_events = overflow_events() - before;
    const Fixed generic = saturate_i128(round_shift(v, Fixed::kFracBits));
    const auto generic_events = overflow_events() - before - fast_events;
    return fast == generic && fast_events == generic_events;
}

TEST(FixedMul, RoundWideMatchesTheGenericRounding) {
    const auto check = round_wide_matches_generic;
    std::vector<i128> edges;
    for (const i128 base : {i128{0}, static_cast<i128>(INT64_MAX) << 32, static_cast<i128>(INT64_MIN) << 32,
                            (static_cast<i128>(INT64_MIN) - 1) << 32, (static_cast<i128>(INT64_MAX) + 1) << 32})
        for (const i128 off : {i128{0}, i128{1}, i128{-1}, i128{1} << 31, (i128{1} << 31) + 1, (i128{1} << 31) - 1,
                               (i128{3} << 31), -(i128{1} << 31), -(i128{3} << 31), i128{1} << 32, -(i128{1} << 32)})
            edges.push_back(base + off);
    edges.push_back(static_cast<i128>(~u128{0} >> 1));
    edges.push_back(-static_cast<i128>(~u128{0} >> 1) - 1);
    for (std::size_t i = 0; i < edges.size(); ++i) ASSERT_TRUE(check(edges[i])) << "edge case " << i;
    std::mt19937_64 g(kSeed + 20);
    for (int i = 0; i < kRandomCases; ++i) {
        // Full-width values, and values whose rounded result is near the int64 range's ends.
        const i128 wide = static_cast<i128>((static_cast<u128>(g()) << 64) | g());
        const i128 near = (static_cast<i128>(static_cast<std::int64_t>(g())) << 32) + static_cast<i128>(g() & 0xFFFFFFFFu);
        const int shift = static_cast<int>(g() % 100);
        ASSERT_TRUE(check(wide)) << i;
        ASSERT_TRUE(check(near)) << i;
        ASSERT_TRUE(check(wide >> shift)) << i;
    }
}

// The fast path's bias-then-test (sim/fixed.h) on a grid: every power of two 2^k (k < 127) and
// its neighbours, both signs, each as the integer part q with every fraction where rounding
// changes (0, 1, half - 1, half, half + 1, one - 1: the ties go to even, so both parities of q
// matter), and the carry from the low word into the high word; the saturation edges (results
// of INT64_MAX, INT64_MIN and one past each, reached by rounding up or down) come out of
// k = 63 and its neighbours.
TEST(FixedMul, RoundWideMatchesTheGenericRoundingNearEveryPowerOfTwo) {
    const i128 kMax = static_cast<i128>(~u128{0} >> 1), kMin = -kMax - 1;
    const i128 half = i128{1} << 31, one = i128{1} << 32;
    const i128 fractions[] = {0, 1, half - 1, half, half + 1, one - 1};
    int checked = 0;
    for (int k = 0; k < 127; ++k)
        for (const i128 delta : {i128{-2}, i128{-1}, i128{0}, i128{1}, i128{2}})
            for (const int sign : {1, -1}) {
                const i128 p = i128{1} << k;
                // q = +-2^k + delta as the integer part (its << 32 kept inside i128)...
                if (k < 95) {
                    const i128 q = sign * p + delta;
                    for (const i128 f : fractions) {
                        ASSERT_TRUE(round_wide_matches_generic(q * one + f)) << k << " " << static_cast<long long>(delta) << " " << sign;
                        ++checked;
                    }
                }
                // ... and +-2^k + delta as the whole value (the low word's carry, tiny values).
                ASSERT_TRUE(round_wide_matches_generic(sign * p + delta)) << k;
                ++checked;
            }
    for (const i128 v : {kMax, kMax - 1, kMax - half, kMax - half + 1, kMin, kMin + 1, kMin + half, i128{0}})
        ASSERT_TRUE(round_wide_matches_generic(v));
    EXPECT_GT(checked, 5000);
}

TEST(FixedMul, ExactHalfUlpTiesGoToEven) {
    auto mul = [](std::int64_t a, std::int64_t b) { return (Fixed::from_raw(a) * Fixed::from_raw(b)).raw; };
    const std::int64_t half = std::int64_t{1} << 31;  // 0.5
    EXPECT_EQ(mul(1, half), 0);    // 0.5 ulp -> 0
    EXPECT_EQ(mul(3, half), 2);    // 1.5 ulp -> 2
    EXPECT_EQ(mul(5, half), 2);    // 2.5 ulp -> 2
    EXPECT_EQ(mul(-1, half), 0);   // -0.5 ulp -> 0
    EXPECT_EQ(mul(-3, half), -2);  // -1.5 ulp -> -2
    EXPECT_EQ(mul(-5, half), -2);
    // Random ties: odd a times an odd multiple of 1/2 lands exactly on half an ulp.
    Stats st("mul-ties");
    std::mt19937_64 g(kSeed + 1);
    for (int i = 0; i < 200'000; ++i) {
        const std::int64_t a = random_raw(g) | 1;
        const std::int64_t b = static_cast<std::int64_t>((g() >> (33 + g() % 31)) | 1) << 31;
        ASSERT_TRUE(check_mul(st, a, (g() & 1) ? b : -b));
    }
    EXPECT_EQ(st.ties, st.n) << "every in-range case was constructed to be a tie";
    EXPECT_GT(st.n, 50'000);
}

// ---------------------------------------------------------------- division

// a / b is exactly a.raw * 2^32 / b.raw ulps; b == 0 saturates toward a's sign (0/0 = 0).
bool check_div(Stats& st, std::int64_t a, std::int64_t b) {
    const auto before = overflow_events();
    const Fixed r = Fixed::from_raw(a) / Fixed::from_raw(b);
    const auto events = overflow_events() - before;
    auto input = [&] { return describe(a) + " / " + describe(b); };
    if (b == 0) {
        const std::int64_t want = a > 0 ? INT64_MAX : a < 0 ? INT64_MIN : 0;
        if (r.raw != want || events != 1) {
            ADD_FAILURE() << input() << ": division by zero gave raw " << r.raw << " with " << events << " events";
            return false;
        }
        return true;
    }
    i128 n = static_cast<i128>(a) * kUlpsPerOne, d = b;
    if (d < 0) { n = -n; d = -d; }
    return check_rounded(st, n, d, r.raw, events, input);
}

TEST(FixedDiv, CorrectlyRoundedOnAMillionRandomInputsAndAllEdgePairs) {
    Stats st("div");
    for (auto a : edge_values())
        for (auto b : edge_values()) ASSERT_TRUE(check_div(st, a, b));
    std::mt19937_64 g(kSeed + 2);
    for (int i = 0; i < kRandomCases; ++i) ASSERT_TRUE(check_div(st, random_raw(g), random_raw(g)));
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_GT(st.saturated, 0);
}

// operator/'s 64-bit path (sim/fixed.cpp, divide_fixed) on a grid: dividends and divisors at
// every power of two and its neighbours, both signs, INT64_MIN and INT64_MAX; then quotients at
// the int64 range's ends, where rounding up makes 2^63 (saturates if positive, fits if
// negative) or where the high word of a * 2^32 meets the divisor (the quotient reaches 2^64).
TEST(FixedDiv, CorrectlyRoundedNearEveryPowerOfTwoAndTheRangeEnds) {
    Stats st("div-grid");
    std::vector<std::int64_t> values{INT64_MIN, INT64_MAX, INT64_MIN + 1, INT64_MAX - 1};
    for (int k = 0; k < 63; ++k)
        for (const std::int64_t delta : {-1, 0, 1}) {
            const std::int64_t v = (std::int64_t{1} << k) + delta;
            values.push_back(v);
            values.push_back(-v);
        }
    for (const auto a : values)
        for (const auto b : values) ASSERT_TRUE(check_div(st, a, b));
    // a / b near 2^63 ulps: a = b * 2^31 + d for b < 2^32, where the quotient is 2^63 + d / b.
    std::mt19937_64 g(kSeed + 21);
    for (int i = 0; i < 200'000; ++i) {
        const auto b = static_cast<std::int64_t>((g() >> (32 + g() % 32)) | 1);  // [1, 2^32)
        const std::int64_t d = static_cast<std::int64_t>(g() % 7) - 3 - (i % 2 ? b / 2 : 0);
        std::int64_t a = 0;
        if (__builtin_add_overflow(b << 31, d, &a)) continue;
        ASSERT_TRUE(check_div(st, (g() & 1) ? a : -a, (g() & 1) ? b : -b));
        // The high word of |a| * 2^32 equal to (or one below) |b|: a quotient of 2^64 (or just under).
        const auto c = static_cast<std::int64_t>(g() >> (33 + g() % 31)) | 1;   // < 2^31
        ASSERT_TRUE(check_div(st, (c << 32) + static_cast<std::int64_t>(g() & 0xFFFFFFFFu), c));
        ASSERT_TRUE(check_div(st, -((c << 32) - 1 - static_cast<std::int64_t>(g() & 0xFFFFu)), c));
    }
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_GT(st.saturated, 0);
}

TEST(FixedDiv, ExactHalfUlpTiesGoToEven) {
    auto div = [](std::int64_t a, std::int64_t b) { return (Fixed::from_raw(a) / Fixed::from_raw(b)).raw; };
    const std::int64_t two = 2 * Fixed::kOne;
    EXPECT_EQ(div(1, two), 0);
    EXPECT_EQ(div(3, two), 2);
    EXPECT_EQ(div(5, two), 2);
    EXPECT_EQ(div(-3, two), -2);
    EXPECT_EQ(div(3, -two), -2);
    EXPECT_EQ(div(-1, -two), 0);
    // m(2k+1) / (m 2^33) = (2k+1)/2 ulps: a tie for every m, k.
    Stats st("div-ties");
    std::mt19937_64 g(kSeed + 3);
    for (int i = 0; i < 200'000; ++i) {
        const auto m = static_cast<std::int64_t>((g() >> (35 + g() % 29)) | 1);  // < 2^29
        const auto k = static_cast<std::int64_t>(g() >> (31 + g() % 33));       // < 2^33
        const std::int64_t a = m * (2 * k + 1), b = m << 33;
        ASSERT_TRUE(check_div(st, (g() & 1) ? a : -a, (g() & 1) ? b : -b));
    }
    EXPECT_EQ(st.ties, st.n);
    EXPECT_EQ(st.n, 200'000);
}

TEST(FixedDiv, ByZeroSaturatesTowardTheDividendAndCounts) {
    const auto before = overflow_events();
    EXPECT_EQ(Fixed::one() / Fixed::zero(), Fixed::max());
    EXPECT_EQ(-Fixed::one() / Fixed::zero(), Fixed::min());
    EXPECT_EQ(Fixed::zero() / Fixed::zero(), Fixed::zero());
    EXPECT_EQ(Fixed::ratio(-7, 0), Fixed::min());
    EXPECT_EQ(reciprocal(Fixed::zero()), Fixed::max());
    EXPECT_EQ(overflow_events() - before, 5u);
}

// ---------------------------------------------------------------- reciprocal and ratio

TEST(FixedReciprocal, CorrectlyRoundedOnAMillionRandomInputs) {
    Stats st("reciprocal");
    auto check = [&](std::int64_t a) {
        const auto before = overflow_events();
        const Fixed r = reciprocal(Fixed::from_raw(a));
        const auto events = overflow_events() - before;
        if (a == 0) return r == Fixed::max() && events == 1;
        // 1 / (a / 2^32) = 2^64 / a ulps.
        i128 n = i128{1} << 64, d = a;
        if (d < 0) { n = -n; d = -d; }
        return check_rounded(st, n, d, r.raw, events, [&] { return std::string("1 / ") + describe(a); });
    };
    for (auto a : edge_values()) ASSERT_TRUE(check(a)) << describe(a);
    std::mt19937_64 g(kSeed + 4);
    for (int i = 0; i < kRandomCases; ++i) {
        const std::int64_t a = random_raw(g);
        ASSERT_TRUE(check(a)) << describe(a);
    }
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_EQ(reciprocal(Fixed::from_raw(INT64_MIN)).raw, -2);  // 1 / -2^31 = -2^-31
}

TEST(FixedRatio, CorrectlyRoundedOnAMillionRandomIntegerPairs) {
    Stats st("ratio");
    auto check = [&](std::int64_t num, std::int64_t den) {
        const auto before = overflow_events();
        const Fixed r = Fixed::ratio(num, den);
        const auto events = overflow_events() - before;
        if (den == 0) return r.raw == (num > 0 ? INT64_MAX : num < 0 ? INT64_MIN : 0) && events == 1;
        i128 n = static_cast<i128>(num) * kUlpsPerOne, d = den;
        if (d < 0) { n = -n; d = -d; }
        return check_rounded(st, n, d, r.raw, events,
                             [&] { return std::string("ratio(") + std::to_string(num) + ", " + std::to_string(den) + ")"; });
    };
    for (auto a : edge_values())
        for (auto b : edge_values()) ASSERT_TRUE(check(a, b)) << a << " / " << b;
    std::mt19937_64 g(kSeed + 5);
    for (int i = 0; i < kRandomCases; ++i) {
        const std::int64_t a = random_raw(g), b = random_raw(g);
        ASSERT_TRUE(check(a, b)) << a << " / " << b;
    }
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_EQ(Fixed::ratio(1, 10).raw, 429496730);  // 429496729.6 rounds up
    EXPECT_EQ(Fixed::ratio(1, 3).raw, 1431655765);  // 1431655765.33 rounds down
}

// ---------------------------------------------------------------- square root

TEST(FixedSqrt, CorrectlyRoundedOnAMillionRandomInputs) {
    Stats st("sqrt");
    auto check = [&](std::int64_t a) {
        const auto before = overflow_events();
        const Fixed r = sqrt(Fixed::from_raw(a));
        const auto events = overflow_events() - before;
        if (a < 0) return r == Fixed::zero() && events == 1;
        // sqrt(a / 2^32) = sqrt(a * 2^32) / 2^32: the rounded square root of the integer a*2^32.
        return events == 0 && check_sqrt(st, static_cast<u128>(a) << 32, static_cast<std::uint64_t>(r.raw),
                                         [&] { return std::string("sqrt ") + describe(a); });
    };
    for (auto a : edge_values()) ASSERT_TRUE(check(a)) << describe(a);
    std::mt19937_64 g(kSeed + 6);
    for (int i = 0; i < kRandomCases; ++i) {
        const std::int64_t a = random_raw(g);
        ASSERT_TRUE(check(a)) << describe(a);
    }
    st.report();
    EXPECT_LT(st.max_err, 0.5L) << "an integer radicand never has a square root exactly halfway";
}

TEST(FixedSqrt, ExactSquaresAndTheEnds) {
    for (std::int64_t k : {0, 1, 2, 3, 100, 46340}) EXPECT_EQ(sqrt(Fixed::from_int(k * k)), Fixed::from_int(k));
    EXPECT_EQ(sqrt(Fixed::from_raw(1)).raw, 65536);  // sqrt(2^-32) = 2^-16
    EXPECT_EQ(sqrt(Fixed::max()).raw, 199032864766430);  // round(sqrt((2^63-1) * 2^32))
    const auto before = overflow_events();
    EXPECT_EQ(sqrt(Fixed::from_raw(-1)), Fixed::zero());
    EXPECT_EQ(sqrt(Fixed::min()), Fixed::zero());
    EXPECT_EQ(overflow_events() - before, 2u);
}

TEST(FixedSqrt, IntegerSquareRootsOverTheWhole128BitDomain) {
    const u128 top = ~u128{0};
    EXPECT_EQ(isqrt_floor(top), UINT64_MAX);
    EXPECT_EQ(isqrt_floor(static_cast<u128>(UINT64_MAX) * UINT64_MAX), UINT64_MAX);
    EXPECT_EQ(isqrt_floor(static_cast<u128>(UINT64_MAX) * UINT64_MAX - 1), UINT64_MAX - 1);
    // sqrt(2^128 - 1) is 2^64 - 2^-65: rounds to 2^64, which does not fit; the contract saturates.
    EXPECT_EQ(isqrt_round(top), UINT64_MAX);
    std::mt19937_64 g(kSeed + 7);
    for (int i = 0; i < 100'000; ++i) {
        const int bits = static_cast<int>(g() % 128) + 1;
        u128 n = (static_cast<u128>(g()) << 64 | g()) >> (128 - bits);
        const std::uint64_t f = isqrt_floor(n);
        const u128 f2 = static_cast<u128>(f) * f;
        ASSERT_TRUE(f2 <= n && (f == UINT64_MAX || n - f2 <= 2 * static_cast<u128>(f))) << bits;
    }
}

// isqrt_floor starts Newton's iteration from a table of the radicand's top bits (sim/fixed.cpp);
// a start below floor(sqrt(n)) would stop at once with a result too small. The edges of every
// root: k^2 - 1, k^2 and k^2 + 2k (the largest radicand whose root floors to k), for k of every
// size and at the powers of two, where the table's buckets begin and end.
TEST(FixedSqrt, IntegerSquareRootsAtTheEdgesOfEveryRoot) {
    std::mt19937_64 g(kSeed + 8);
    const auto check = [](std::uint64_t k) {
        const u128 sq = static_cast<u128>(k) * k;
        ASSERT_EQ(isqrt_floor(sq), k);
        if (k > 0) {
            ASSERT_EQ(isqrt_floor(sq - 1), k - 1);
        }
        if (k < UINT64_MAX) {
            ASSERT_EQ(isqrt_floor(sq + 2 * static_cast<u128>(k)), k);
            ASSERT_EQ(isqrt_floor(sq + 2 * static_cast<u128>(k) + 1), k + 1);
        }
    };
    for (int bits = 1; bits <= 64; ++bits) {
        const std::uint64_t p = std::uint64_t{1} << (bits - 1);
        for (std::uint64_t d = 0; d < 64; ++d) {
            check(p + d);
            check(p - d);
        }
        for (int i = 0; i < 20'000; ++i) check((g() >> (64 - bits)) | p);
    }
}

// isqrt_floor runs radicands below 2^64 on 64-bit words, squares included (sim/fixed.cpp), which
// holds only while every iterate stays below 2^32, as the table's start keeps them. Each bucket of the start table's top bits at
// the high end of that range, where the start is up to 2^-7 high, checked against the root's
// defining bounds r^2 <= n < (r + 1)^2.
TEST(FixedSqrt, IntegerSquareRootsAtTheTopOfTheWordRange) {
    std::mt19937_64 g(kSeed + 9);
    const auto check = [](u128 n) {
        const std::uint64_t r = isqrt_floor(n);
        const u128 r2 = static_cast<u128>(r) * r;
        ASSERT_TRUE(r2 <= n && n - r2 <= 2 * static_cast<u128>(r)) << static_cast<std::uint64_t>(n);
        ASSERT_EQ(isqrt_round(n), n - r2 > r ? r + 1 : r) << static_cast<std::uint64_t>(n);
    };
    for (int len = 60; len <= 66; ++len) {
        for (u128 top = 128; top < 512; ++top) {
            const int e = (len - 8) & ~1;
            if (top >> (len - e - 1) != 1) continue;  // top must have len - e bits
            const u128 lo = top << e, hi = (top + 1) << e;
            for (u128 n : {lo, lo + 1, hi - 1, hi - 2}) check(n);
            for (int i = 0; i < 2'000; ++i) check(lo + (static_cast<u128>(g()) % (hi - lo)));
        }
    }
    for (std::uint64_t j = 0; j < 100'000; ++j) check(~std::uint64_t{0} - j);
}

// ---------------------------------------------------------------- add, subtract, negate

TEST(FixedAddSub, ExactOrSaturatedWithOneOverflowEventOnAMillionRandomInputs) {
    long saturated = 0;
    auto check = [&](std::int64_t a, std::int64_t b, bool subtract) {
        const auto before = overflow_events();
        const Fixed r = subtract ? Fixed::from_raw(a) - Fixed::from_raw(b) : Fixed::from_raw(a) + Fixed::from_raw(b);
        const auto events = overflow_events() - before;
        const i128 exact = subtract ? static_cast<i128>(a) - b : static_cast<i128>(a) + b;
        if (exact > INT64_MAX) return ++saturated, r == Fixed::max() && events == 1;
        if (exact < INT64_MIN) return ++saturated, r == Fixed::min() && events == 1;
        return r.raw == exact && events == 0;
    };
    for (auto a : edge_values())
        for (auto b : edge_values())
            for (bool s : {false, true}) ASSERT_TRUE(check(a, b, s)) << a << (s ? " - " : " + ") << b;
    std::mt19937_64 g(kSeed + 8);
    for (int i = 0; i < kRandomCases; ++i) {
        // Both near the top of the range half of the time, so overflow is common.
        std::int64_t a = random_raw(g), b = random_raw(g);
        if (i & 1) { a = static_cast<std::int64_t>(g()); b = static_cast<std::int64_t>(g()); }
        ASSERT_TRUE(check(a, b, false)) << a << " + " << b;
        ASSERT_TRUE(check(a, b, true)) << a << " - " << b;
    }
    std::printf("[accuracy] add/sub    %d cases exact, %ld saturated with exactly one overflow event each\n",
                2 * kRandomCases, saturated);
    EXPECT_GT(saturated, kRandomCases / 4);
}

TEST(FixedAddSub, NegateAbsAndIntegerScaleSaturateAtTheAsymmetricEnd) {
    const auto before = overflow_events();
    EXPECT_EQ(-Fixed::min(), Fixed::max());
    EXPECT_EQ(abs(Fixed::min()), Fixed::max());
    EXPECT_EQ(-Fixed::max(), Fixed::from_raw(INT64_MIN + 1));
    EXPECT_EQ(Fixed::min() * std::int64_t{-1}, Fixed::max());
    EXPECT_EQ(Fixed::max() * std::int64_t{2}, Fixed::max());
    EXPECT_EQ(Fixed::max() * std::int64_t{-2}, Fixed::min());
    EXPECT_EQ(overflow_events() - before, 5u);
    EXPECT_EQ(Fixed::from_raw(-5) * std::int64_t{3}, Fixed::from_raw(-15));
    EXPECT_EQ(Fixed::min() * std::int64_t{1}, Fixed::min());
    EXPECT_EQ(overflow_events() - before, 5u);
}

TEST(FixedFromInt, RangeIsMinusTwoToThe31UpToButExcludingTwoToThe31) {
    const auto before = overflow_events();
    EXPECT_EQ(Fixed::from_int(2147483647).raw, std::int64_t{2147483647} << 32);
    EXPECT_EQ(Fixed::from_int(-2147483648LL), Fixed::min());
    EXPECT_EQ(overflow_events() - before, 0u);
    EXPECT_EQ(Fixed::from_int(2147483648LL), Fixed::max());
    EXPECT_EQ(Fixed::from_int(-2147483649LL), Fixed::min());
    EXPECT_EQ(Fixed::from_int(INT64_MIN), Fixed::min());
    EXPECT_EQ(overflow_events() - before, 3u);
}

TEST(FixedOverflowEvents, AreCountedPerThread) {
    const auto main_before = overflow_events();
    std::uint64_t in_thread_start = 99, in_thread_end = 0;
    std::thread t([&] {
        in_thread_start = overflow_events();
        (void)(Fixed::max() + Fixed::one());
        (void)(Fixed::max() * Fixed::max());
        in_thread_end = overflow_events();
    });
    t.join();
    EXPECT_EQ(in_thread_start, 0u);
    EXPECT_EQ(in_thread_end, 2u);
    EXPECT_EQ(overflow_events(), main_before);
}

// ---------------------------------------------------------------- parsing

std::optional<Fixed> parse(std::string_view s) { return Fixed::parse(s); }
// The raw value parse gives, or nullopt: compare with EXPECT_EQ(raw_of(text), value).
std::optional<std::int64_t> raw_of(std::string_view s) {
    const auto f = Fixed::parse(s);
    return f ? std::optional<std::int64_t>(f->raw) : std::nullopt;
}

TEST(FixedParse, KnownValuesAreTheNearestQ32_32) {
    EXPECT_EQ(raw_of("0.1"), 429496730);  // 0.1 * 2^32 = 429496729.6
    EXPECT_EQ(raw_of("-0.1"), -429496730);
    EXPECT_EQ(raw_of("1"), Fixed::kOne);
    EXPECT_EQ(raw_of("+1"), Fixed::kOne);
    EXPECT_EQ(raw_of("-0"), 0);
    EXPECT_EQ(raw_of("0.5"), std::int64_t{1} << 31);
    EXPECT_EQ(raw_of(".5"), std::int64_t{1} << 31);
    EXPECT_EQ(raw_of("5."), 5 * Fixed::kOne);
    EXPECT_EQ(raw_of("0005.2500"), 21 * (Fixed::kOne / 4));
    EXPECT_EQ(raw_of("1e-3"), 4294967);  // 4294967.296
    EXPECT_EQ(raw_of("2.5E+2"), 250 * Fixed::kOne);
    EXPECT_EQ(raw_of("15e-1"), 3 * (Fixed::kOne / 2));
    EXPECT_EQ(raw_of("0.00000000023283064365386962890625"), 1);  // 2^-32
    EXPECT_EQ(raw_of("2147483647.99999999976716935634613037109375"), INT64_MAX);
    EXPECT_EQ(raw_of("-2147483648"), INT64_MIN);
    EXPECT_EQ(raw_of("-2.147483648e9"), INT64_MIN);
    EXPECT_EQ(raw_of("123456789012345678901234567890123456e-35"), 5302428713);  // 1.2345... * 2^32 = 5302428712.77
    EXPECT_EQ(raw_of("1e-400"), 0);
    EXPECT_EQ(raw_of("0e400"), 0);
}

TEST(FixedParse, HalfUlpTiesGoToEvenAndAnyDigitBeyondBreaksThem) {
    // 2^-33 and 3 * 2^-33 (half and one and a half ulps), exactly.
    EXPECT_EQ(raw_of("0.000000000116415321826934814453125"), 0);
    EXPECT_EQ(raw_of("-0.000000000116415321826934814453125"), 0);
    EXPECT_EQ(raw_of("0.000000000349245965480804443359375"), 2);
    EXPECT_EQ(raw_of("-0.000000000349245965480804443359375"), -2);
    EXPECT_EQ(raw_of("0.0000000001164153218269348144531250000001"), 1);
    EXPECT_EQ(raw_of("0.0000000001164153218269348144531249999999"), 0);
    // max + half an ulp rounds to 2^63 (even): out of range. min - half an ulp rounds to min.
    EXPECT_FALSE(parse("2147483647.999999999883584678173065185546875"));
    EXPECT_EQ(raw_of("2147483647.999999999883584678173065185546874999"), INT64_MAX);
    EXPECT_EQ(raw_of("-2147483648.000000000116415321826934814453125"), INT64_MIN);
    EXPECT_FALSE(parse("-2147483648.0000000001164153218269348144531250001"));
}

// Exact decimal text of m * 2^-33 (m >= 0), independent of Fixed::to_string.
std::string half_ulp_decimal(u128 m) {
    std::string s = accuracy::u128_string(m >> 33);
    std::uint64_t frac = static_cast<std::uint64_t>(m & ((u128{1} << 33) - 1));
    if (frac) s += '.';
    while (frac) {
        frac *= 10;
        s += static_cast<char>('0' + (frac >> 33));
        frac &= (std::uint64_t{1} << 33) - 1;
    }
    return s;
}

TEST(FixedParse, RandomHalfUlpTiesAndTheirNeighboursRoundCorrectly) {
    std::mt19937_64 g(kSeed + 9);
    for (int i = 0; i < 100'000; ++i) {
        const auto u = static_cast<std::uint64_t>(random_raw(g) & INT64_MAX);  // magnitude in [0, 2^63)
        const bool negative = g() & 1;
        const std::string sign = negative ? "-" : "";
        const std::string tie = half_ulp_decimal(2 * static_cast<u128>(u) + 1);  // (u + 1/2) ulps
        ASSERT_EQ(tie.back(), '5');
        std::string below = tie, above = tie + "000000001";
        below.back() = '4';
        below += "99999999";
        auto expect = [&](const std::string& text, std::uint64_t mag) {
            const auto r = parse(sign + text);
            const u128 limit = negative ? u128{1} << 63 : (u128{1} << 63) - 1;
            if (mag > limit) {
                ASSERT_FALSE(r) << sign + text;
                return;
            }
            ASSERT_TRUE(r) << sign + text;
            const i128 want = negative ? -static_cast<i128>(mag) : static_cast<i128>(mag);
            ASSERT_EQ(static_cast<i128>(r->raw), want) << sign + text;
        };
        expect(tie, (u & 1) ? u + 1 : u);
        expect(below, u);
        expect(above, u + 1);
        if (HasFatalFailure()) return;
    }
}

// A random decimal numeral and its exact value mantissa * 10^e10.
struct Decimal {
    std::string text;
    bool negative = false;
    std::uint64_t mantissa = 0;  // below 10^19
    int e10 = 0;
};

Decimal random_decimal(std::mt19937_64& g) {
    Decimal d;
    const int sign = static_cast<int>(g() % 3);
    d.negative = sign == 2;
    if (sign) d.text += sign == 1 ? '+' : '-';
    const int n = 1 + static_cast<int>(g() % 19);
    const int point = static_cast<int>(g() % (n + 2)) - 1;  // -1: no point
    std::string digits;
    for (int k = 0; k < n; ++k) {
        const char c = static_cast<char>('0' + g() % 10);
        digits += c;
        d.mantissa = d.mantissa * 10 + static_cast<std::uint64_t>(c - '0');
    }
    if (point < 0) {
        d.text += digits;
    } else {
        d.text += digits.substr(0, static_cast<std::size_t>(point)) + "." + digits.substr(static_cast<std::size_t>(point));
        d.e10 = -(n - point);
    }
    if (g() % 3 == 0) {
        const int e = static_cast<int>(g() % 43) - 30;  // [-30, 12]
        d.text += (g() & 1) ? 'e' : 'E';
        if (e >= 0 && (g() & 1)) d.text += '+';
        d.text += std::to_string(e);
        d.e10 += e;
    }
    return d;
}

TEST(FixedParse, CorrectlyRoundedOnAMillionRandomNumerals) {
    Stats st("parse");
    long rejected = 0;
    std::mt19937_64 g(kSeed + 10);
    for (int i = 0; i < kRandomCases; ++i) {
        const Decimal d = random_decimal(g);
        const auto before = overflow_events();
        const auto r = parse(d.text);
        ASSERT_EQ(overflow_events(), before) << "parsing validates, it never saturates: " << d.text;
        auto input = [&] { return std::string("\"") + d.text + "\""; };
        // Exact value as N / D ulps. Parsing rejects what the rounded value cannot hold.
        i128 n = 0, den = 1;
        bool out_of_range = false;
        if (d.mantissa == 0) {
            n = 0;
        } else if (d.e10 >= 0) {
            if (d.e10 > 10) {
                out_of_range = true;  // >= 1e11
            } else {
                i128 v = d.mantissa;
                for (int k = 0; k < d.e10; ++k) v *= 10;  // < 10^29
                if (v > (i128{1} << 31)) out_of_range = true;
                else n = v << 32;
            }
        } else if (-d.e10 > 38) {
            n = 0;  // below 10^19 * 10^-39 = 1e-20, far under half an ulp (1.16e-10): rounds to 0
        } else {
            n = static_cast<i128>(d.mantissa) << 32;
            for (int k = 0; k < -d.e10; ++k) den *= 10;
        }
        if (d.negative) n = -n;
        if (!out_of_range) out_of_range = expect_for(n, den) != Expect::InRange;
        if (out_of_range) {
            ASSERT_FALSE(r) << input() << " is outside the range, got raw " << r->raw;
            ++rejected;
            continue;
        }
        ASSERT_TRUE(r) << input() << " was rejected";
        ASSERT_TRUE(check_rounded(st, n, den, r->raw, 0, input));
    }
    st.report();
    std::printf("[accuracy] parse      %ld numerals out of range, all rejected\n", rejected);
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_GT(rejected, 0);
    EXPECT_GT(st.n, kRandomCases / 2);
}

TEST(FixedParse, RejectsGarbage) {
    const char* bad[] = {"",     "+",   "-",    ".",     "+.",  "e1",  ".e1",   "1e",   "1e+",  "1e-",
                         "1.2.3", "1..2", "--1", "+-1",  " 1",  "1 ",  "1\n",   "1,5",  "0x10", "inf",
                         "-inf",  "nan", "1e5.5", "1e1e1", "1f", "1d",  "1_000", "١",   "e",    "1e+-1"};
    for (const char* s : bad) EXPECT_FALSE(parse(s)) << "\"" << s << "\"";
    EXPECT_FALSE(parse(std::string_view("1\0", 2))) << "embedded NUL";
}

TEST(FixedParse, RejectsOutOfRangeInsteadOfSaturating) {
    const char* bad[] = {"2147483648", "-2147483649", "2147483648.0", "1e10", "21474836480e-1",
                         "2147483647.9999999999",  // nearest Q32.32 value is 2^31
                         "-2147483648.0000000002", "99999999999999999999", "1e11", "-1e400",
                         "1e401",  // exponents beyond +-400 are rejected outright
                         "1e-401", "1e99999999999999999999"};
    const auto before = overflow_events();
    for (const char* s : bad) EXPECT_FALSE(parse(s)) << s;
    EXPECT_EQ(overflow_events(), before);
}

TEST(FixedParse, SignificantDigitLimit) {
    // Any Q32.32 value needs at most 42 significant digits (10 integer + 32 fraction); 64 are
    // accepted, more are rejected. Leading zeros are not significant; trailing ones are.
    const std::string sixty_four = "1." + std::string(63, '0');
    EXPECT_EQ(raw_of(sixty_four), Fixed::kOne);
    EXPECT_FALSE(parse(sixty_four + "0"));
    EXPECT_EQ(raw_of("0." + std::string(300, '0') + "1"), 0);
    EXPECT_EQ(raw_of(std::string(300, '0') + "7"), 7 * Fixed::kOne);
}

// ---------------------------------------------------------------- to_string

// Checks s is exactly raw / 2^32 in decimal with no trailing fractional zeros, without using
// parse: integer part I and k fraction digits F satisfy F / 10^k == f / 2^32 (f = low 32 bits of
// |raw|), i.e. f * 5^k == F * 2^(32 - k), which fits in 128 bits for k <= 32.
::testing::AssertionResult to_string_exact(std::int64_t raw, const std::string& s) {
    const u128 mag = raw < 0 ? static_cast<u128>(0) - static_cast<u128>(static_cast<i128>(raw)) : static_cast<u128>(raw);
    std::string want_int = accuracy::u128_string(mag >> 32);
    if (raw < 0) want_int.insert(want_int.begin(), '-');
    const auto dot = s.find('.');
    if (s.substr(0, dot) != want_int) return ::testing::AssertionFailure() << "integer part of " << s;
    const u128 f = mag & 0xFFFFFFFFu;
    if (dot == std::string::npos) return f == 0 ? ::testing::AssertionSuccess() : ::testing::AssertionFailure() << s;
    const std::string frac = s.substr(dot + 1);
    const int k = static_cast<int>(frac.size());
    if (k == 0 || k > 32 || frac.back() == '0') return ::testing::AssertionFailure() << "fraction format of " << s;
    u128 F = 0, five = 1;
    for (char c : frac) F = F * 10 + static_cast<unsigned>(c - '0');
    for (int i = 0; i < k; ++i) five *= 5;
    if (f * five != F << (32 - k)) return ::testing::AssertionFailure() << s << " is not exactly raw " << raw;
    return ::testing::AssertionSuccess();
}

TEST(FixedToString, IsExactAndRoundTripsThroughParse) {
    EXPECT_EQ(Fixed::zero().to_string(), "0");
    EXPECT_EQ(Fixed::one().to_string(), "1");
    EXPECT_EQ((-Fixed::one()).to_string(), "-1");
    EXPECT_EQ(Fixed::from_raw(-(std::int64_t{1} << 31)).to_string(), "-0.5");
    EXPECT_EQ(Fixed::from_raw(1).to_string(), "0.00000000023283064365386962890625");
    EXPECT_EQ(Fixed::max().to_string(), "2147483647.99999999976716935634613037109375");
    EXPECT_EQ(Fixed::min().to_string(), "-2147483648");
    for (auto v : edge_values()) {
        const std::string s = Fixed::from_raw(v).to_string();
        ASSERT_TRUE(to_string_exact(v, s));
        ASSERT_EQ(parse(s), Fixed::from_raw(v)) << s;
    }
    std::mt19937_64 g(kSeed + 11);
    for (int i = 0; i < kRandomCases; ++i) {
        const std::int64_t v = (i & 1) ? random_raw(g) : static_cast<std::int64_t>(g());
        const std::string s = Fixed::from_raw(v).to_string();
        ASSERT_TRUE(to_string_exact(v, s));
        const auto back = parse(s);
        ASSERT_TRUE(back) << s << " (raw " << v << ") does not parse";
        ASSERT_EQ(back->raw, v) << s;
    }
}

}  // namespace
}  // namespace lockroll::sim
