// sim/vec3.h's Quat: products, rotations, the exponential-map step and deterministic renormalisation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sim/vec3.h"

namespace lockroll::sim {
namespace {

double d(Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }
Fixed fx(double v) { return Fixed::from_raw(static_cast<std::int64_t>(std::llround(v * 4294967296.0))); }

TEST(Quat, IdentityRotatesNothing) {
    const Mat3 r = rotation(Quat{});
    const Vec3 v{fx(1.25), fx(-2), fx(0.5)};
    EXPECT_EQ(r * v, v);
}

TEST(Quat, QuarterTurnAboutZMapsXToY) {
    const double h = std::sqrt(0.5);
    const Quat q = normalised({fx(h), Fixed::zero(), Fixed::zero(), fx(h)});
    const Vec3 v = rotation(q) * Vec3{Fixed::one(), Fixed::zero(), Fixed::zero()};
    EXPECT_NEAR(d(v.x), 0, 1e-8);
    EXPECT_NEAR(d(v.y), 1, 1e-8);
    EXPECT_NEAR(d(v.z), 0, 1e-8);
}

TEST(Quat, IntegratedMatchesTheExactTurnForConstantRate) {
    // 600 steps of 1/60 s at 2 rad/s about a skew axis: 20 rad in all.
    const Vec3 axis{fx(0.6), fx(0.8), Fixed::zero()};
    const Vec3 w = axis * Fixed::from_int(2);
    Quat q;
    const Fixed dt = Fixed::ratio(1, 60);
    for (int i = 0; i < 600; ++i) q = integrated(q, w, dt);
    const double angle = 600 * d(dt) * 2;
    EXPECT_NEAR(d(q.w), std::cos(angle / 2), 2e-6);
    EXPECT_NEAR(d(q.x), 0.6 * std::sin(angle / 2), 2e-6);
    EXPECT_NEAR(d(q.y), 0.8 * std::sin(angle / 2), 2e-6);
    EXPECT_EQ(q.z, Fixed::zero());
}

TEST(Quat, RenormalisedIsUnitAndOnTheGrid) {
    Quat q{fx(0.5003), fx(0.5), fx(-0.4998), fx(0.5)};
    for (int i = 0; i < 3; ++i) q = renormalised(q);
    const double len = std::sqrt(d(q.w) * d(q.w) + d(q.x) * d(q.x) + d(q.y) * d(q.y) + d(q.z) * d(q.z));
    EXPECT_NEAR(len, 1.0, 4e-9);
    for (Fixed c : {q.w, q.x, q.y, q.z}) EXPECT_EQ(c.raw % 4, 0) << "component off the 2^-30 grid";
}

TEST(Quat, RotateDiagonalIsRDRt) {
    const double h = std::sqrt(0.5);
    const Mat3 r = rotation(normalised({fx(h), Fixed::zero(), Fixed::zero(), fx(h)}));
    const Mat3 m = rotate_diagonal(r, {fx(1), fx(2), fx(3)});
    // A quarter turn about z swaps the x and y moments.
    EXPECT_NEAR(d(m.row[0].x), 2, 1e-8);
    EXPECT_NEAR(d(m.row[1].y), 1, 1e-8);
    EXPECT_NEAR(d(m.row[2].z), 3, 1e-8);
    EXPECT_NEAR(d(m.row[0].y), 0, 1e-8);
    EXPECT_EQ(m.row[0].y, m.row[1].x);
}

// Components far from unit length (a body spun past any sane rate) must saturate and count,
// never overflow the 128-bit sums (undefined behaviour; scene_fuzz found it under UBSan).
TEST(Quat, ProductOfHugeComponentsSaturatesAndCounts) {
    const Fixed big = Fixed::max();
    const Quat a{big, big, big, big};
    const Quat b{big, -big, -big, -big};  // w component: 4 products of +2^126 each
    const auto before = overflow_events();
    const Quat p = a * b;
    EXPECT_EQ(p.w, Fixed::max());
    EXPECT_GE(overflow_events() - before, 1u);
    const Quat n = a * Quat{Fixed::min(), big, big, big};  // w: -2^126 - 3 * 2^126 (rounded)
    EXPECT_EQ(n.w, Fixed::min());
}

// A spin far past any sane rate turns by the 2 rad cap, about the right axis, and stays a unit
// quaternion with no overflow (the small-angle series would otherwise grow without bound).
TEST(Quat, HugeTurnIsCappedAndStaysUnit) {
    const auto before = overflow_events();
    const Quat q = integrated(Quat{}, {Fixed::zero(), Fixed::zero(), fx(1.0e6)}, Fixed::ratio(1, 60));
    EXPECT_EQ(overflow_events(), before);
    const double n = d(q.w) * d(q.w) + d(q.x) * d(q.x) + d(q.y) * d(q.y) + d(q.z) * d(q.z);
    EXPECT_NEAR(n, 1.0, 1e-8);
    // Half angle 1 rad about z; the series to a^6 errs by ~2e-5 there (renormalised after).
    EXPECT_NEAR(d(q.w), std::cos(1.0), 1e-4);
    EXPECT_NEAR(d(q.z), std::sin(1.0), 1e-4);
    EXPECT_EQ(q.x, Fixed::zero());
}

// sim/quat.cpp's integrated() and renormalised() as they were before their shortcuts (every
// power of s multiplied out, the renormalisation's four products taken even for f = 1): the
// general arithmetic the shortcuts must match bit for bit.
Fixed to_grid_general(Fixed f) {
    const std::int64_t g = round_shift(f.raw, 2);
    if (g > INT64_MAX / 4 || g < INT64_MIN / 4) {
        note_overflow();
        return g > 0 ? Fixed::max() : Fixed::min();
    }
    return Fixed::from_raw(g * 4);
}
Quat renormalised_general(const Quat& q) {
    const Fixed s = quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
    const Fixed f = Fixed::from_raw((3 * Fixed::kOne - s.raw) / 2);
    return {to_grid_general(q.w * f), to_grid_general(q.x * f), to_grid_general(q.y * f), to_grid_general(q.z * f)};
}
Quat integrated_general(const Quat& q, const Vec3& w, Fixed dt) {
    const Fixed half_dt = Fixed::from_raw(dt.raw / 2);
    Vec3 a = w * half_dt;
    Fixed s = dot(a, a);
    if (s > Fixed::one()) {
        const Fixed len = length(a);
        a = {a.x / len, a.y / len, a.z / len};
        s = dot(a, a);
    }
    const Fixed s2 = s * s, s3 = s2 * s;
    const Fixed c24 = Fixed::ratio(1, 24), c720 = Fixed::ratio(1, 720), k6 = Fixed::ratio(1, 6),
                k120 = Fixed::ratio(1, 120), k5040 = Fixed::ratio(1, 5040);
    const Fixed c = Fixed::one() - Fixed::from_raw(s.raw / 2) + s2 * c24 - s3 * c720;
    const Fixed k = Fixed::one() - s * k6 + s2 * k120 - s3 * k5040;
    const Quat dq{c, a.x * k, a.y * k, a.z * k};
    return renormalised_general(dq * q);
}

// integrated() skips the products of a power of s that rounds to 0 and the renormalisation's
// products by f = 1; it must give exactly the general arithmetic's bits (and overflow count)
// for rates from a crawl to a fuzzed spin, on grid orientations and off them.
TEST(Quat, IntegratedShortcutsGiveTheGeneralBits) {
    std::mt19937_64 rng(1919);
    std::uniform_real_distribution<double> u(-1, 1);
    const Fixed dt = Fixed::ratio(1, 60);
    int s2_zero = 0, s3_zero = 0, f_one = 0, full = 0;
    for (int i = 0; i < 300000; ++i) {
        // Rates over 12 orders of magnitude (1e-6 to 1e6 rad/s), each component its own scale.
        const auto rate = [&] { return fx(u(rng) * std::pow(10.0, 6 * u(rng))); };
        const Vec3 w{rate(), rate(), rate()};
        Quat q = normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))});
        // Off the grid and off unit length by a few ulps sometimes, as a product leaves it.
        if (i % 3 == 0) q = {q.w + Fixed::from_raw(i % 7 - 3), q.x, q.y - Fixed::from_raw(i % 5), q.z};
        const std::uint64_t before = overflow_events();
        const Quat got = integrated(q, w, dt);
        const std::uint64_t got_events = overflow_events() - before;
        const Quat want = integrated_general(q, w, dt);
        ASSERT_EQ(got, want) << i;
        ASSERT_EQ(got_events, overflow_events() - before - got_events) << i;
        const Vec3 a = w * Fixed::from_raw(dt.raw / 2);
        const Fixed s = dot(a, a), s2 = s * s;
        s2_zero += s2.raw == 0;
        s3_zero += s2.raw != 0 && (s2 * s).raw == 0;
        full += (s2 * s).raw != 0;
        const Quat r = renormalised(q);
        ASSERT_EQ(r, renormalised_general(q)) << i;
        const Fixed sq = quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
        f_one += (3 * Fixed::kOne - sq.raw) / 2 == Fixed::kOne;
    }
    EXPECT_GT(s2_zero, 10000);  // every case is exercised
    EXPECT_GT(s3_zero, 10000);
    EXPECT_GT(full, 10000);
    EXPECT_GT(f_one, 10000);
}

TEST(Quat, CrossIsRightHanded) {
    const Vec3 x{Fixed::one(), Fixed::zero(), Fixed::zero()}, y{Fixed::zero(), Fixed::one(), Fixed::zero()};
    EXPECT_EQ(cross(x, y), (Vec3{Fixed::zero(), Fixed::zero(), Fixed::one()}));
}

}  // namespace
}  // namespace lockroll::sim
