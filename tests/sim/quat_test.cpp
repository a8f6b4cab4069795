// sim/vec3.h's Quat: products, rotations, the exponential-map step and deterministic renormalisation.
#include <gtest/gtest.h>

#include <cmath>

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

TEST(Quat, CrossIsRightHanded) {
    const Vec3 x{Fixed::one(), Fixed::zero(), Fixed::zero()}, y{Fixed::zero(), Fixed::one(), Fixed::zero()};
    EXPECT_EQ(cross(x, y), (Vec3{Fixed::zero(), Fixed::zero(), Fixed::one()}));
}

}  // namespace
}  // namespace lockroll::sim
