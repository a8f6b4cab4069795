// Accuracy and edge cases of Vec3 (sim/vec3.h): dot and length are rounded once from exact
// wide sums, so they are held to the same 0.5-ulp standard as the scalar operations; the
// component-wise operations must behave exactly like the scalar ones, overflow counting included.
#include "sim/vec3.h"

#include <gtest/gtest.h>

#include <random>
#include <utility>

#include "tests/sim/accuracy.h"

namespace lockroll::sim {
namespace {

using namespace accuracy;
using accuracy::i128;  // the builtin references, not sim's (possibly portable) i128
using accuracy::u128;

Vec3 raw3(std::int64_t x, std::int64_t y, std::int64_t z) {
    return {Fixed::from_raw(x), Fixed::from_raw(y), Fixed::from_raw(z)};
}

std::string describe(const Vec3& v) {
    std::string s = "(";
    s += accuracy::describe(v.x.raw);
    s += ", ";
    s += accuracy::describe(v.y.raw);
    s += ", ";
    s += accuracy::describe(v.z.raw);
    s += ')';
    return s;
}

// Mostly magnitude-spread components; every 16th vector has full-range ones so that the wide
// sums overflow and saturation is exercised too.
Vec3 random_vec(std::mt19937_64& g, int i) {
    if (i % 16 == 15) return raw3(static_cast<std::int64_t>(g()), static_cast<std::int64_t>(g()), static_cast<std::int64_t>(g()));
    const std::int64_t x = random_raw(g), y = random_raw(g), z = random_raw(g);
    return raw3(x, y, z);
}

// The exact a.b in ulps^2 (Q64.64) as H * 2^64 + L with 0 <= L < 2^64: three 128-bit products
// can exceed the i128 range, this 192-bit sum cannot.
struct WideSum {
    i128 hi = 0;
    u128 lo = 0;
    bool fits() const { return hi >= -(i128{1} << 63) && hi < (i128{1} << 63); }
    i128 value() const { return static_cast<i128>((static_cast<u128>(hi) << 64) | lo); }
};

WideSum exact_dot(const Vec3& a, const Vec3& b) {
    WideSum s;
    for (auto [p, q] : {std::pair{a.x, b.x}, std::pair{a.y, b.y}, std::pair{a.z, b.z}}) {
        const i128 prod = static_cast<i128>(p.raw) * q.raw;
        s.hi += prod >> 64;
        s.lo += static_cast<std::uint64_t>(prod);
    }
    s.hi += static_cast<i128>(s.lo >> 64);
    s.lo &= UINT64_MAX;
    return s;
}

bool check_dot(Stats& st, const Vec3& a, const Vec3& b) {
    const auto before = overflow_events();
    const Fixed r = dot(a, b);
    const auto events = overflow_events() - before;
    auto input = [&] { return describe(a) + " . " + describe(b); };
    const WideSum s = exact_dot(a, b);
    if (!s.fits()) {  // |a.b| >= 2^127 ulps^2 = 2^95 ulps: far beyond the range
        ++st.saturated;
        const Fixed want = s.hi < 0 ? Fixed::min() : Fixed::max();
        if (r != want || events != 1) {
            ADD_FAILURE() << "dot " << input() << ": expected saturation with exactly one overflow event, got raw "
                          << r.raw << " and " << events << " events";
            return false;
        }
        return true;
    }
    return check_rounded(st, s.value(), i128{1} << 32, r.raw, events, input);
}

TEST(Vec3Dot, CorrectlyRoundedOnAMillionRandomInputs) {
    Stats st("dot");
    std::mt19937_64 g(kSeed + 20);
    for (int i = 0; i < kRandomCases; ++i) {
        const Vec3 a = random_vec(g, i), b = random_vec(g, i);
        ASSERT_TRUE(check_dot(st, a, b));
    }
    st.report();
    EXPECT_LE(st.max_err, 0.5L);
    EXPECT_GT(st.saturated, 0);
}

TEST(Vec3Dot, HugeProductsCancelExactlyAndOverflowCountsOnce) {
    Stats st("dot-edges");
    const std::int64_t M = INT64_MAX, m = INT64_MIN, one = Fixed::kOne;
    // max^2 - max^2 + 1 ulp * 1 = 1 ulp: the products need all 126 bits and cancel.
    EXPECT_EQ(dot(raw3(M, M, 1), raw3(M, -M, one)).raw, 1);
    // 2^126 + 2^126 overflows an i128 partial sum; the third term brings the total back to
    // 2^126 + 2^63 (still far out of range): one saturation, one event.
    const Vec3 cases[][2] = {
        {raw3(m, m, m), raw3(m, m, -M)},  {raw3(m, m, m), raw3(m, m, m)},    {raw3(m, m, m), raw3(M, M, M)},
        {raw3(M, m, 1), raw3(M, M, -1)},  {raw3(0, 0, 0), raw3(m, m, m)},    {raw3(1, 1, 1), raw3(1, 1, 1)},
        {raw3(m, 0, 0), raw3(-one, 0, 0)}, {raw3(m, 0, 0), raw3(-1, 0, 0)}, {raw3(1, 1, 1), raw3(1 << 30, 1 << 30, 1 << 30)},
    };
    for (const auto& c : cases) ASSERT_TRUE(check_dot(st, c[0], c[1]));
}

TEST(Vec3Length, CorrectlyRoundedOnAMillionRandomInputs) {
    Stats st("length");
    long saturated = 0;
    std::mt19937_64 g(kSeed + 21);
    const u128 limit = static_cast<u128>(INT64_MAX) * INT64_MAX + INT64_MAX;  // rounds to <= max
    for (int i = 0; i < kRandomCases; ++i) {
        const Vec3 v = random_vec(g, i);
        const auto before = overflow_events();
        const Fixed r = length(v);
        const auto events = overflow_events() - before;
        u128 n = 0;
        for (auto c : {v.x.raw, v.y.raw, v.z.raw}) {
            const u128 m = c < 0 ? static_cast<u128>(0) - static_cast<u128>(static_cast<i128>(c)) : static_cast<u128>(c);
            n += m * m;  // <= 3 * 2^126
        }
        ASSERT_EQ(length_sq_wide(v), n) << describe(v);
        if (n > limit) {
            ++saturated;
            ASSERT_TRUE(r == Fixed::max() && events == 1) << "|" << describe(v) << "| gave raw " << r.raw;
            continue;
        }
        ASSERT_EQ(events, 0u) << describe(v);
        ASSERT_TRUE(check_sqrt(st, n, static_cast<std::uint64_t>(r.raw), [&] {
            std::string s = "|";
            s += describe(v);
            s += '|';
            return s;
        }));
    }
    st.report();
    std::printf("[accuracy] length     %ld saturated with exactly one overflow event each\n", saturated);
    EXPECT_LT(st.max_err, 0.5L);
    EXPECT_GT(saturated, 0);
}

TEST(Vec3Length, KnownValuesAndTheEnds) {
    EXPECT_EQ(length(raw3(3 * Fixed::kOne, 4 * Fixed::kOne, 0)), Fixed::from_int(5));
    EXPECT_EQ(length(raw3(0, -12 * Fixed::kOne, 5 * Fixed::kOne)), Fixed::from_int(13));
    EXPECT_EQ(length(raw3(1, 0, 0)).raw, 1);
    EXPECT_EQ(length(raw3(1, 1, 1)).raw, 2);  // sqrt(3) = 1.73 ulps
    EXPECT_EQ(length(raw3(0, 0, 0)).raw, 0);
    const auto before = overflow_events();
    EXPECT_EQ(length(raw3(INT64_MAX, 0, 0)), Fixed::max());
    EXPECT_EQ(length(raw3(0, 0, -INT64_MAX)), Fixed::max());
    EXPECT_EQ(overflow_events(), before);
    EXPECT_EQ(length(raw3(INT64_MIN, 0, 0)), Fixed::max());  // 2^63 ulps does not fit
    EXPECT_EQ(length(raw3(INT64_MIN, INT64_MIN, INT64_MIN)), Fixed::max());
    EXPECT_EQ(overflow_events() - before, 2u);
}

// Runs f and returns its result with the number of overflow events it caused.
template <class F>
std::pair<Vec3, std::uint64_t> counted(F&& f) {
    const auto before = overflow_events();
    const Vec3 v = f();
    return {v, overflow_events() - before};
}

TEST(Vec3Arithmetic, ComponentWiseExactlyLikeTheScalarOperations) {
    std::mt19937_64 g(kSeed + 22);
    long saturating = 0;
    for (int i = 0; i < 100'000; ++i) {
        const Vec3 a = random_vec(g, i), b = random_vec(g, i);
        const Fixed s = Fixed::from_raw(random_raw(g));
        // Reference: the scalar operations (their own tests are in fixed_test.cpp), including
        // how many overflow events they count.
        const std::pair<Vec3, std::uint64_t> want[] = {
            counted([&] { return Vec3{a.x + b.x, a.y + b.y, a.z + b.z}; }),
            counted([&] { return Vec3{a.x - b.x, a.y - b.y, a.z - b.z}; }),
            counted([&] { return Vec3{-a.x, -a.y, -a.z}; }),
            counted([&] { return Vec3{a.x * s, a.y * s, a.z * s}; }),
            counted([&] { return Vec3{a.x * s, a.y * s, a.z * s}; }),
            counted([&] { return Vec3{a.x + b.x, a.y + b.y, a.z + b.z}; }),
            counted([&] { return Vec3{a.x - b.x, a.y - b.y, a.z - b.z}; }),
        };
        const std::pair<Vec3, std::uint64_t> got[] = {
            counted([&] { return a + b; }),
            counted([&] { return a - b; }),
            counted([&] { return -a; }),
            counted([&] { return a * s; }),
            counted([&] { return s * a; }),
            counted([&] { Vec3 v = a; v += b; return v; }),
            counted([&] { Vec3 v = a; v -= b; return v; }),
        };
        for (int k = 0; k < 7; ++k) {
            ASSERT_EQ(got[k].first, want[k].first) << "operation " << k << " on " << describe(a) << ", " << describe(b);
            ASSERT_EQ(got[k].second, want[k].second) << "operation " << k << " on " << describe(a) << ", " << describe(b);
            saturating += want[k].second != 0;
        }
    }
    EXPECT_GT(saturating, 0);
}

}  // namespace
}  // namespace lockroll::sim
