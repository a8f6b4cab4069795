// The portable 128-bit integers (sim/fixed.h's integer layer) against the compiler's __int128.
//
// Every operation of UInt128 / Int128 and the helpers sim/ computes with (mul_wide, divmod,
// add/sub/mul_overflow) is run on seeded random operands and on every pair of edge values, and
// each result must equal the builtin's bit for bit. The class is tested in every build; the
// helpers are whichever implementation this build uses (LOCKROLL_PORTABLE_MATH=ON makes them
// the portable ones, and the rest of the suite then runs on them too).
#include "sim/fixed.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

namespace lockroll::sim {
namespace {

using B = __int128;
using BU = unsigned __int128;

constexpr int kRandomCases = 300'000;

std::string hex(BU v) {
    static const char* digits = "0123456789abcdef";
    std::string s;
    for (int k = 31; k >= 0; --k) s.push_back(digits[static_cast<int>((v >> (4 * k)) & 15)]);
    return "0x" + s;
}

// Operands spread over bit lengths 0..128 (uniform 128-bit values are almost all huge and never
// exercise one-word divisors or small quotients), with random sign.
BU random_wide(std::mt19937_64& g) {
    const int bits = static_cast<int>(g() % 129);
    BU v = (static_cast<BU>(g()) << 64) | g();
    if (bits < 128) v &= (BU{1} << bits) - 1;
    if (bits > 0) v |= BU{1} << (bits - 1);
    return v;
}

std::vector<BU> edge_values() {
    std::vector<BU> out;
    const BU base[] = {0,
                       1,
                       2,
                       3,
                       0xFFFFFFFFu,
                       BU{1} << 32,
                       (BU{1} << 63) - 1,
                       BU{1} << 63,
                       (BU{1} << 64) - 1,
                       BU{1} << 64,
                       (BU{1} << 64) + 1,
                       (BU{1} << 96) - 1,
                       (BU{1} << 127) - 1,
                       BU{1} << 127,
                       ~BU{0},
                       (BU{0xFFFFFFFFu} << 64) | 0xFFFFFFFFu};
    for (BU b : base) {
        out.push_back(b);
        out.push_back(BU{0} - b);
    }
    return out;
}

BU bits(UInt128 v) { return static_cast<BU>(v); }
BU bits(Int128 v) { return static_cast<BU>(v); }

// Checks every unsigned and signed operation on one operand pair; returns false on the first
// difference (with a message), so a failing run stops instead of printing a million lines.
bool check_pair(BU x, BU y) {
    const UInt128 a = x, b = y;
    const auto expect = [&](const char* op, BU got, BU want) {
        if (got == want) return true;
        ADD_FAILURE() << op << " of " << hex(x) << ", " << hex(y) << ": got " << hex(got) << ", want " << hex(want);
        return false;
    };
    const int s = static_cast<int>(y % 128);
    bool ok = expect("u+", bits(a + b), x + y) && expect("u-", bits(a - b), x - y) && expect("u*", bits(a * b), x * y) &&
              expect("u&", bits(a & b), x & y) && expect("u|", bits(a | b), x | y) && expect("u^", bits(a ^ b), x ^ y) &&
              expect("u~", bits(~a), ~x) && expect("u neg", bits(-a), BU{0} - x) && expect("u<<", bits(a << s), x << s) &&
              expect("u>>", bits(a >> s), x >> s) && expect("u<", a < b, x < y) && expect("u==", a == b, x == y);
    if (ok && y != 0) {
        UInt128 q, r;
        divmod(a, b, q, r);
        ok = expect("u/", bits(a / b), x / y) && expect("u%", bits(a % b), x % y) && expect("divmod q", bits(q), x / y) &&
             expect("divmod r", bits(r), x % y);
    }
    const B sx = static_cast<B>(x), sy = static_cast<B>(y);
    const Int128 c = sx, d = sy;
    const auto sbits = [](B v) { return static_cast<BU>(v); };
    ok = ok && expect("s+", bits(c + d), x + y) && expect("s-", bits(c - d), x - y) && expect("s*", bits(c * d), x * y) &&
         expect("s>>", bits(c >> s), sbits(sx >> s)) && expect("s<<", bits(c << s), x << s) && expect("s<", c < d, sx < sy) &&
         expect("s<=", c <= d, sx <= sy) && expect("s neg", bits(-c), BU{0} - x);
    // Builtin signed division overflows only for min / -1; the class wraps there (not tested).
    const bool overflow = sx == static_cast<B>(BU{1} << 127) && sy == -1;
    if (ok && sy != 0 && !overflow)
        ok = expect("s/", bits(c / d), sbits(sx / sy)) && expect("s%", bits(c % d), sbits(sx % sy));
    return ok;
}

TEST(WideInt, PortableClassMatchesBuiltinOnEdgePairs) {
    const auto edges = edge_values();
    int pairs = 0;
    for (BU x : edges)
        for (BU y : edges) {
            ASSERT_TRUE(check_pair(x, y));
            ++pairs;
        }
    EXPECT_EQ(pairs, 32 * 32);
}

TEST(WideInt, PortableClassMatchesBuiltinOnRandomPairs) {
    std::mt19937_64 g(20261201);
    for (int i = 0; i < kRandomCases; ++i) ASSERT_TRUE(check_pair(random_wide(g), random_wide(g)));
}

// Divisions whose estimated quotient digit needs the correction steps: divisors with a full
// top word and dividends just below a multiple of them.
TEST(WideInt, DivisionCorrectionPaths) {
    std::mt19937_64 g(7);
    for (int i = 0; i < kRandomCases; ++i) {
        const BU d = (static_cast<BU>(g() | (std::uint64_t{1} << 63)) << (g() % 65)) >> (g() % 64);  // >= 1
        const BU qmax = (~BU{0} - (d - 1)) / d;  // q * d + d - 1 must not wrap
        const BU q = qmax == ~BU{0} ? random_wide(g) : random_wide(g) % (qmax + 1);
        const BU n = q * d + (g() & 1 ? d - 1 : 0);
        UInt128 qq, rr;
        divmod(UInt128(n), UInt128(d), qq, rr);
        ASSERT_EQ(bits(qq), n / d) << hex(n) << " / " << hex(d);
        ASSERT_EQ(bits(rr), n % d) << hex(n) << " % " << hex(d);
    }
}

TEST(WideInt, ConversionsKeepLowBitsAndSignExtend) {
    EXPECT_EQ(bits(UInt128(std::int64_t{-1})), ~BU{0});
    EXPECT_EQ(bits(Int128(std::int32_t{-5})), static_cast<BU>(B{-5}));
    EXPECT_EQ(bits(UInt128(std::uint64_t{~0ull})), BU{~0ull});
    EXPECT_EQ(static_cast<std::int64_t>(Int128(B{-7} << 70 | 3)), 3);
    EXPECT_EQ(static_cast<std::int8_t>(Int128(-300)), static_cast<std::int8_t>(-300));
    EXPECT_TRUE(static_cast<bool>(UInt128::from_words(1, 0)));
    EXPECT_FALSE(static_cast<bool>(UInt128{}));
    EXPECT_EQ(bits(UInt128(Int128(-1))), ~BU{0});
    EXPECT_EQ(Int128(UInt128(~BU{0})), Int128(-1));
    static_assert(((UInt128(1) << 100) >> 99) == 2, "usable in constant expressions");
}

// The compound assignments and increments (one CRTP base, wide_detail::CompoundOps, for both
// classes) are their binary operators assigned, and return the object they changed; the base
// adds nothing to either class's two words.
template <class T>
void check_compound(T a, T b, int s) {
    const auto same = [](T& r, T& x, T want) { return &r == &x && r == want; };
    T x = a;
    EXPECT_TRUE(same(x += b, x, a + b));
    EXPECT_TRUE(same(x = a, x, a) && same(x -= b, x, a - b));
    EXPECT_TRUE(same(x = a, x, a) && same(x *= b, x, a * b));
    EXPECT_TRUE(same(x = a, x, a) && same(x &= b, x, a & b));
    EXPECT_TRUE(same(x = a, x, a) && same(x |= b, x, a | b));
    EXPECT_TRUE(same(x = a, x, a) && same(x ^= b, x, a ^ b));
    EXPECT_TRUE(same(x = a, x, a) && same(x <<= s, x, a << s));
    EXPECT_TRUE(same(x = a, x, a) && same(x >>= s, x, a >> s));
    EXPECT_TRUE(same(x = a, x, a) && same(++x, x, a + T(1)));
    EXPECT_TRUE(same(x = a, x, a) && same(--x, x, a - T(1)));
    if (b != T(0)) {
        EXPECT_TRUE(same(x = a, x, a) && same(x /= b, x, a / b));
        EXPECT_TRUE(same(x = a, x, a) && same(x %= b, x, a % b));
    }
}

TEST(WideInt, CompoundAssignmentsAreTheirOperators) {
    static_assert(sizeof(UInt128) == 16 && sizeof(Int128) == 16);
    static_assert(std::is_trivially_copyable_v<UInt128> && std::is_trivially_copyable_v<Int128>);
    static_assert(std::is_standard_layout_v<UInt128> && std::is_standard_layout_v<Int128>);
    static_assert([] {
        UInt128 u = 5;
        u <<= 70;
        u += 3;
        ++u;
        return u == ((UInt128(5) << 70) + 4);
    }(), "usable in constant expressions");
    const auto edges = edge_values();
    for (BU x : edges)
        for (BU y : edges) {
            check_compound(UInt128(x), UInt128(y), static_cast<int>(y % 128));
            check_compound(Int128(static_cast<B>(x)), Int128(static_cast<B>(y)), static_cast<int>(x % 128));
        }
}

// The helpers in the implementation this build uses (builtin or portable) against __int128.
TEST(WideInt, ActiveHelpersMatchBuiltin) {
    std::mt19937_64 g(99);
    std::vector<std::int64_t> v = {0, 1, -1, 2, -2, INT64_MAX, INT64_MIN, INT64_MAX - 1, INT64_MIN + 1,
                                   std::int64_t{1} << 32, -(std::int64_t{1} << 32), std::int64_t{3037000499}, -std::int64_t{3037000500}};
    for (int i = 0; i < kRandomCases; ++i) {
        const int bits_len = static_cast<int>(g() % 64);
        const auto m = static_cast<std::int64_t>(g() >> (63 - bits_len) >> 1);
        v.push_back(g() & 1 ? -m : m);
    }
    for (std::size_t i = 0; i + 1 < v.size(); ++i) {
        for (std::size_t j : {i + 1, v.size() - 1 - i % 13}) {
            const std::int64_t a = v[i], b = v[j];
            ASSERT_EQ(static_cast<B>(mul_wide(a, b)), static_cast<B>(a) * b) << a << " * " << b;
            const auto ua = static_cast<std::uint64_t>(a), ub = static_cast<std::uint64_t>(b);
            ASSERT_EQ(static_cast<BU>(mul_wide_unsigned(ua, ub)), static_cast<BU>(ua) * ub) << ua << " * " << ub;
            std::int64_t r = 0, want = 0;
            ASSERT_EQ(add_overflow(a, b, &r), __builtin_add_overflow(a, b, &want)) << a << " + " << b;
            ASSERT_EQ(r, want);
            ASSERT_EQ(sub_overflow(a, b, &r), __builtin_sub_overflow(a, b, &want)) << a << " - " << b;
            ASSERT_EQ(r, want);
            ASSERT_EQ(mul_overflow(a, b, &r), __builtin_mul_overflow(a, b, &want)) << a << " * " << b;
            ASSERT_EQ(r, want);
            // 128-bit add overflow on products (the dot product's partial sums).
            // Doubled products (wrapping in unsigned arithmetic) reach +-2^127, so sums overflow.
            const B p = static_cast<B>(static_cast<BU>(static_cast<B>(a) * b) << 1);
            const B q = static_cast<B>(static_cast<BU>(static_cast<B>(b) * b) << 1);
            i128 s{};
            B ws = 0;
            ASSERT_EQ(add_overflow(i128(p), i128(q), &s), __builtin_add_overflow(p, q, &ws));
            ASSERT_EQ(static_cast<B>(s), ws);
        }
    }
}

TEST(WideInt, BuildReportsItsImplementation) {
#if defined(LOCKROLL_PORTABLE_MATH) && LOCKROLL_PORTABLE_MATH
    EXPECT_EQ(LOCKROLL_BUILTIN_INT128, 0);
    EXPECT_TRUE((std::is_same_v<i128, Int128>));
#else
    EXPECT_EQ(LOCKROLL_BUILTIN_INT128, 1);
    EXPECT_TRUE((std::is_same_v<i128, __int128>));
#endif
    std::printf("[wide_int] 128-bit implementation: %s\n", LOCKROLL_BUILTIN_INT128 ? "builtin __int128" : "portable (32-bit halves)");
}

}  // namespace
}  // namespace lockroll::sim
