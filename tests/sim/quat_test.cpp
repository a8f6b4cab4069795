// sim/vec3.h's Quat: products, rotations, the exponential-map step and deterministic renormalisation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

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
    const quat_detail::SeriesCoefficients& k = quat_detail::kSeries;
    int s2_zero = 0, s3_zero = 0, f_one = 0, full = 0, s2_terms_skipped = 0, s3_terms_skipped = 0;
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
        // Powers that do not round to 0 but whose terms all do (skipped by the thresholds).
        s2_terms_skipped += s2.raw != 0 && s.raw <= k.s2_terms_zero_up_to;
        s3_terms_skipped += (s2 * s).raw != 0 && s.raw > k.s2_terms_zero_up_to && s.raw <= k.s3_terms_zero_up_to;
        const Quat r = renormalised(q);
        ASSERT_EQ(r, renormalised_general(q)) << i;
        const Fixed sq = quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
        f_one += (3 * Fixed::kOne - sq.raw) / 2 == Fixed::kOne;
    }
    EXPECT_GT(s2_zero, 10000);  // every case is exercised
    EXPECT_GT(s3_zero, 10000);
    EXPECT_GT(full, 10000);
    EXPECT_GT(f_one, 10000);
    // renormalised() takes x * f for f = 1 + d ulp in 64 bits: components of 1/2 (raw 2^31) put
    // x d / 2^32 exactly on a tie for every odd d, rounded to even either way as x * f is.
    int ties = 0;
    for (std::int64_t e = -40; e <= 40; ++e) {
        const Fixed h = Fixed::from_raw(std::int64_t{1} << 31);
        for (const Quat q : {Quat{h, h, h, h + Fixed::from_raw(e)}, Quat{h + Fixed::from_raw(e), -h, h, -h},
                             Quat{h + Fixed::from_raw(3 * e), h, -h - Fixed::from_raw(e), h}}) {
            ASSERT_EQ(renormalised(q), renormalised_general(q)) << e;
            const Fixed sq = quat_detail::sum4(q.w, q.w, q.x, q.x, q.y, q.y, q.z, q.z);
            ties += ((3 * Fixed::kOne - sq.raw) / 2 - Fixed::kOne) % 2 != 0;
        }
    }
    EXPECT_GT(ties, 20);
    EXPECT_GT(s2_terms_skipped, 3000);  // a narrow band: |w| from 0.39 to 0.86 rad/s
    EXPECT_GT(s3_terms_skipped, 10000);
    // Rates about one axis swept in single ulps of a across each threshold (every s.raw from
    // 12 below to 12 above it is reached): the bits at the edges.
    int at_edge = 0;
    for (const std::int64_t edge : {k.s2_terms_zero_up_to, k.s3_terms_zero_up_to}) {
        const auto a_edge = static_cast<std::int64_t>(std::sqrt(static_cast<double>(edge) * 4294967296.0));
        for (std::int64_t da = -200; da <= 200; ++da) {
            const Vec3 w{Fixed::from_raw((a_edge + da) * 120), Fixed::zero(), Fixed::zero()};
            const Vec3 a = w * Fixed::from_raw(dt.raw / 2);
            at_edge += dot(a, a).raw == edge || dot(a, a).raw == edge + 1;
            const Quat q = normalised({fx(0.3), fx(-0.5), fx(0.7), fx(0.1)});
            ASSERT_EQ(integrated(q, w, dt), integrated_general(q, w, dt)) << edge << " " << da;
        }
    }
    EXPECT_GE(at_edge, 4);
}

// integrated() takes the Hamilton product of a step's rotation dq = (c, v) near 1 (|c - 1| +
// |v_x| + |v_y| + |v_z| below 2^30 raw) in 64-bit products; it must give operator*'s bits:
// rates swept in single ulps of a = w dt / 2 across that bound about each axis and about a
// diagonal, and orientations of components 1/2 (raw 2^31), which put a product's remainder
// exactly on a tie whenever its sum of raw factors is odd.
TEST(Quat, NearOneProductGivesTheGeneralBits) {
    const Fixed dt = Fixed::ratio(1, 60);
    const Fixed h = Fixed::from_raw(std::int64_t{1} << 31);
    const Quat halves[] = {Quat{h, h, h, h}, Quat{h, -h, h, -h}, Quat{-h, h, -h, -h}};
    std::mt19937_64 rng(2019);
    std::uniform_real_distribution<double> u(-1, 1);
    // dq as integrated_general() forms it, to count the sweep's cases on each side of the bound.
    const auto sum_of_dq = [&](const Vec3& w) {
        const Vec3 a = w * Fixed::from_raw(dt.raw / 2);
        const Fixed s = dot(a, a), s2 = s * s, s3 = s2 * s;
        const Fixed c = Fixed::one() - Fixed::from_raw(s.raw / 2) + s2 * Fixed::ratio(1, 24) - s3 * Fixed::ratio(1, 720);
        const Fixed k = Fixed::one() - s * Fixed::ratio(1, 6) + s2 * Fixed::ratio(1, 120) - s3 * Fixed::ratio(1, 5040);
        return std::llabs(c.raw - Fixed::kOne) + std::llabs((a.x * k).raw) + std::llabs((a.y * k).raw) +
               std::llabs((a.z * k).raw);
    };
    constexpr std::int64_t kBound = std::int64_t{1} << 30;
    int near = 0, beyond = 0;
    for (const Vec3 dir : {Vec3{Fixed::one(), Fixed::zero(), Fixed::zero()}, Vec3{Fixed::zero(), -Fixed::one(), Fixed::zero()},
                           Vec3{Fixed::zero(), Fixed::zero(), Fixed::one()}, Vec3{Fixed::one(), -Fixed::one(), Fixed::one()}}) {
        // The largest a along dir with sum_of_dq below the bound (the sum grows with a), by
        // bisection; the sweep runs single ulps of a on both sides of it.
        std::int64_t lo = 0, hi = Fixed::kOne / 2;
        while (hi - lo > 1) {
            const std::int64_t mid = lo + (hi - lo) / 2;
            (sum_of_dq(dir * Fixed::from_raw(mid * 120)) < kBound ? lo : hi) = mid;
        }
        const std::int64_t t_edge = lo;
        for (std::int64_t e = -400; e <= 400; ++e) {
            const Fixed a = Fixed::from_raw(t_edge + e);
            const Vec3 w = dir * Fixed::from_raw(a.raw * 120);  // a = w dt / 2 along dir, within a few ulps
            (sum_of_dq(w) < kBound ? near : beyond) += 1;
            for (const Quat& q0 : halves) ASSERT_EQ(integrated(q0, w, dt), integrated_general(q0, w, dt)) << e;
            const Quat q = normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))});
            ASSERT_EQ(integrated(q, w, dt), integrated_general(q, w, dt)) << e;
        }
    }
    EXPECT_GT(near, 800);  // both sides of the bound, about every direction
    EXPECT_GT(beyond, 800);
    // Slower rates on the halves: ties in most components.
    for (int i = 0; i < 20000; ++i) {
        const Vec3 w{fx(u(rng) * 6), fx(u(rng) * 6), fx(u(rng) * 6)};
        for (const Quat& q0 : halves) ASSERT_EQ(integrated(q0, w, dt), integrated_general(q0, w, dt)) << i;
    }
}

// integrated() takes a tame rate (|w_i| < 2^40 and |dt / 2| < 2^31 raw, |w_i dt / 2| within
// 2^30 raw) in 64-bit products without range checks; it must give the general arithmetic's bits
// and overflow count: at and one ulp either side of each bound (w, dt / 2 and a = w dt / 2 about
// each axis and a diagonal, a few ulps beyond 2^30 where int64 sums of squares would still fit
// if the bound were larger), at exact ties of w dt / 2 (dt / 2 = 2^-k), and at random rates.
TEST(Quat, TameRateShortcutGivesTheGeneralBits) {
    std::mt19937_64 rng(2119);
    std::uniform_real_distribution<double> u(-1, 1);
    const Quat q0 = normalised({fx(0.3), fx(-0.5), fx(0.7), fx(0.1)});
    int tame = 0, wild = 0;  // cases the shortcut took and left
    const auto same = [&](const Quat& q, const Vec3& w, Fixed dt) {
        const std::uint64_t before = overflow_events();
        const Quat got = integrated(q, w, dt);
        const std::uint64_t got_events = overflow_events() - before;
        const Quat want = integrated_general(q, w, dt);
        if (got != want || got_events != overflow_events() - before - got_events) return false;
        // The shortcut's own a, c and k (the final rounding to the 2^-30 grid would hide an
        // ulp's difference in them): integrated_general()'s, when it applies.
        const Fixed half_dt = Fixed::from_raw(dt.raw / 2);
        Vec3 a;
        Fixed c, k;
        if (!quat_detail::tame_half_turn(w, half_dt, a, c, k)) return ++wild, true;
        ++tame;
        const Vec3 ga = w * half_dt;
        const Fixed s = dot(ga, ga), s2 = s * s, s3 = s2 * s;
        const Fixed gc = Fixed::one() - Fixed::from_raw(s.raw / 2) + s2 * Fixed::ratio(1, 24) - s3 * Fixed::ratio(1, 720);
        const Fixed gk = Fixed::one() - s * Fixed::ratio(1, 6) + s2 * Fixed::ratio(1, 120) - s3 * Fixed::ratio(1, 5040);
        return a == ga && c == gc && k == gk;
    };
    constexpr std::int64_t kA = std::int64_t{1} << 30, kW = std::int64_t{1} << 40, kH = std::int64_t{1} << 31;
    const Fixed z = Fixed::zero();
    int checked = 0;
    for (const Fixed dt : {Fixed::ratio(1, 60), Fixed::ratio(1, 240), Fixed::ratio(1, 7), -Fixed::ratio(1, 60),
                           Fixed::from_raw(2 * kH - 2), Fixed::from_raw(2 * kH), Fixed::from_raw(2 * kH + 2),
                           Fixed::from_raw(std::int64_t{1} << 20), Fixed::from_raw(2)}) {
        const std::int64_t h = dt.raw / 2;
        // a = w dt / 2 swept across +-2^30 (and up to 2^33, where the squares' sum passes 2^63).
        for (const std::int64_t target : {kA, -kA, kA + kA / 2, 2 * kA, 4 * kA, 8 * kA, kA / 3}) {
            // Clamped to +-2^62 (for the tiniest dt the edge lies past the int64 range; there the
            // rate is far beyond the 2^40 bound anyway), so w_edge + e step cannot overflow.
            const long double edge = (static_cast<long double>(target) * 4294967296.0L) / h;
            constexpr long double kClamp = 4611686018427387904.0L;  // 2^62
            const std::int64_t w_edge = static_cast<std::int64_t>(std::clamp(edge, -kClamp, kClamp));
            for (std::int64_t e = -6; e <= 6; ++e) {
                const Fixed wv = Fixed::from_raw(w_edge + e * std::max<std::int64_t>(1, 4294967296 / std::llabs(h) / 4));
                for (const Vec3 w : {Vec3{wv, z, z}, Vec3{z, -wv, z}, Vec3{z, z, wv}, Vec3{wv, wv, -wv}, Vec3{wv, Fixed::from_raw(wv.raw / 2), wv}}) {
                    ASSERT_TRUE(same(q0, w, dt)) << dt.raw << " " << target << " " << e;
                    ++checked;
                }
            }
        }
        // w across +-2^40 raw.
        for (std::int64_t e = -3; e <= 3; ++e) {
            const Fixed wv = Fixed::from_raw(kW + e);
            for (const Vec3 w : {Vec3{wv, z, z}, Vec3{z, -wv, z}, Vec3{z, z, wv}, Vec3{-wv, -wv, -wv}})
                ASSERT_TRUE(same(q0, w, dt)) << dt.raw << " " << e;
        }
    }
    // Ties: dt / 2 = 2^-k makes w_i dt / 2 land exactly halfway between grid points for odd w_i.
    for (int k = 1; k <= 12; ++k) {
        const Fixed dt = Fixed::from_raw(std::int64_t{1} << (33 - k));
        for (std::int64_t i = -40; i <= 40; ++i) {
            const Vec3 w{Fixed::from_raw(2 * i + 1), Fixed::from_raw(3 * i + 5), Fixed::from_raw((i << 20) + 1)};
            ASSERT_TRUE(same(q0, w, dt)) << k << " " << i;
        }
    }
    // Ties in s = |a|^2: with dt / 2 = 1/4 (a = w / 4 exactly) and a_i = 2^15 m_i or 2^14 m_i,
    // the sum of squares is a multiple of 2^28 that sits halfway between grid points whenever
    // sum m_i^2 is 2 mod 4 (or 8 mod 16), on both even and odd quotients.
    int s_ties = 0;
    for (const int shift : {17, 16})
        for (std::int64_t m1 = -12; m1 <= 12; ++m1)
            for (std::int64_t m2 = -12; m2 <= 12; ++m2)
                for (std::int64_t m3 = -12; m3 <= 12; ++m3) {
                    const Vec3 w{Fixed::from_raw(m1 << shift), Fixed::from_raw(m2 << shift), Fixed::from_raw(m3 << shift)};
                    const std::int64_t sq = (m1 * m1 + m2 * m2 + m3 * m3) << (2 * (shift - 2));
                    s_ties += (sq & 0xFFFFFFFF) == 0x80000000;
                    ASSERT_TRUE(same(q0, w, Fixed::from_raw(kH))) << shift << " " << m1 << " " << m2 << " " << m3;
                }
    EXPECT_GT(s_ties, 1000);
    // Random rates from 0.3 rad/s to far past the bound, random orientations.
    for (int i = 0; i < 100000; ++i) {
        const auto rate = [&] { return fx(u(rng) * std::pow(10.0, 2.5 + 3 * u(rng))); };
        const Vec3 w{rate(), rate(), rate()};
        const Quat q = normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))});
        ASSERT_TRUE(same(q, w, i % 2 ? Fixed::ratio(1, 60) : Fixed::ratio(1, 120))) << i;
    }
    EXPECT_GT(checked, 3000);
    EXPECT_GT(tame, 30000);  // both sides of the bounds
    EXPECT_GT(wild, 20000);
}

// rotate_scaled() takes R diag(d) R^T l by plain 128-bit sums when q is within [-2, 2] and the
// vectors below 2^55 raw; it must give the general products' bits and overflow count: q at and
// one ulp beyond +-2 (R's entries up to 16), l and the scaled vector at and beyond +-2^55 (up
// to 2^62, where unchecked sums with entries of 16 would pass 2^94), and random unit q.
TEST(Quat, RotateScaledGivesTheGeneralBits) {
    std::mt19937_64 rng(2219);
    std::uniform_real_distribution<double> u(-1, 1);
    const auto general = [](const Mat3& r, const Vec3& d, const Vec3& l) {
        const Vec3 t = transpose_times(r, l);
        return r * Vec3{d.x * t.x, d.y * t.y, d.z * t.z};
    };
    const auto same = [&](const Quat& q, const Vec3& d, const Vec3& l) {
        const Mat3 r = rotation(q);
        const std::uint64_t before = overflow_events();
        const Vec3 got = rotate_scaled(q, r, d, l);
        const std::uint64_t got_events = overflow_events() - before;
        const Vec3 want = general(r, d, l);
        return got == want && got_events == overflow_events() - before - got_events;
    };
    const std::int64_t two = std::int64_t{1} << 33, v55 = std::int64_t{1} << 55;
    const Fixed t2 = Fixed::from_raw(two);
    std::vector<Quat> qs;
    for (const std::int64_t e : {-1, 0, 1}) {
        const Fixed a = Fixed::from_raw(two + e), b = Fixed::from_raw(-two - e);
        qs.push_back({a, a, a, a});
        qs.push_back({b, a, b, a});
        qs.push_back({a, t2, -t2, Fixed::zero()});
        qs.push_back({Fixed::zero(), a, t2, b});
    }
    for (int i = 0; i < 20; ++i) qs.push_back(normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))}));
    std::vector<std::int64_t> mags;
    for (const int p : {0, 20, 40, 50, 54, 56, 58, 60, 62})
        for (const std::int64_t e : {-1, 0, 1}) mags.push_back((std::int64_t{1} << p) + e);
    mags.push_back(v55 - 1);
    int cases = 0;
    for (const Quat& q : qs)
        for (const std::int64_t m : mags)
            for (const Fixed dd : {Fixed::one(), Fixed::from_raw(3), Fixed::from_raw(std::int64_t{1} << 40)}) {
                const Fixed f = Fixed::from_raw(m);
                for (const Vec3 l : {Vec3{f, f, f}, Vec3{-f, f, -f}, Vec3{f, Fixed::zero(), -f}}) {
                    ASSERT_TRUE(same(q, Vec3{dd, dd, Fixed::one()}, l)) << m << " " << dd.raw;
                    ++cases;
                }
            }
    for (int i = 0; i < 50000; ++i) {
        const Quat q = normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))});
        const auto big = [&] { return fx(u(rng) * std::pow(10.0, 4 * u(rng))); };
        ASSERT_TRUE(same(q, {big(), big(), big()}, {big(), big(), big()})) << i;
    }
    EXPECT_GT(cases, 5000);
}

// rotation() takes quaternions within [-2, 2] by plain int64 sums and products rounded without
// range checks; it must give rotation_general()'s bits: on unit quaternions, on components at
// and one ulp either side of +-2 (the edge of the shortcut), and on components of odd multiples
// of 2^-17 and 2^-16, whose products sit on exact ties (the rounding's ties to even).
TEST(Quat, RotationShortcutGivesTheGeneralBits) {
    std::mt19937_64 rng(1920);
    std::uniform_real_distribution<double> u(-1, 1);
    std::uniform_int_distribution<std::int64_t> odd(-(1 << 16), 1 << 16);
    const auto same = [](const Quat& q) {
        const Mat3 a = rotation(q), b = rotation_general(q);
        for (int i = 0; i < 3; ++i)
            if (!(a.row[i] == b.row[i])) return false;
        return true;
    };
    int ties = 0;
    for (int i = 0; i < 20000; ++i) {
        ASSERT_TRUE(same(normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))}))) << i;
        ASSERT_TRUE(same({fx(2 * u(rng)), fx(2 * u(rng)), fx(2 * u(rng)), fx(2 * u(rng))})) << i;
        const auto tie = [&](int shift) { return Fixed::from_raw((2 * odd(rng) + 1) << shift); };
        const Quat t{tie(15), tie(16), tie(15), tie(16)};
        ASSERT_TRUE(same(t)) << i;
        ties += (mul_wide(t.x.raw, t.y.raw) & 0xFFFFFFFF) == 0x80000000;
    }
    EXPECT_GT(ties, 10000);
    const std::int64_t two = std::int64_t{2} << 32;
    for (std::int64_t e = -2; e <= 2; ++e)
        for (std::int64_t edge : {two + e, -two + e}) {
            const Fixed f = Fixed::from_raw(edge), h = Fixed::from_raw(std::int64_t{3} << 31);
            ASSERT_TRUE(same({f, f, f, f})) << edge;
            ASSERT_TRUE(same({h, f, -h, f})) << edge;
            ASSERT_TRUE(same({f, -h, f, h})) << edge;
        }
}

// The thresholds below which integrated() leaves out the s^2 and s^3 terms are exactly the
// largest s at which those terms, by the general arithmetic, round to 0: one more ulp of s and
// one of them does not.
TEST(Quat, SeriesThresholdsAreTheLargestExact) {
    const quat_detail::SeriesCoefficients& k = quat_detail::kSeries;
    const auto s3_terms_zero = [&](std::int64_t raw) {
        const Fixed s = Fixed::from_raw(raw), s3 = s * s * s;
        return (s3 * Fixed::ratio(1, 720)).raw == 0 && (s3 * Fixed::ratio(1, 5040)).raw == 0;
    };
    const auto s2_terms_zero = [&](std::int64_t raw) {
        const Fixed s = Fixed::from_raw(raw), s2 = s * s;
        return (s2 * Fixed::ratio(1, 24)).raw == 0 && (s2 * Fixed::ratio(1, 120)).raw == 0 && s3_terms_zero(raw);
    };
    EXPECT_EQ(k.c24, Fixed::ratio(1, 24));
    EXPECT_EQ(k.c720, Fixed::ratio(1, 720));
    EXPECT_EQ(k.k6, Fixed::ratio(1, 6));
    EXPECT_EQ(k.k120, Fixed::ratio(1, 120));
    EXPECT_EQ(k.k5040, Fixed::ratio(1, 5040));
    EXPECT_TRUE(s3_terms_zero(k.s3_terms_zero_up_to));
    EXPECT_FALSE(s3_terms_zero(k.s3_terms_zero_up_to + 1));
    EXPECT_TRUE(s2_terms_zero(k.s2_terms_zero_up_to));
    EXPECT_FALSE(s2_terms_zero(k.s2_terms_zero_up_to + 1));
    // Every s below holds as well (the rounded chain is nondecreasing in s): checked on a sweep.
    for (std::int64_t raw = 0; raw <= k.s3_terms_zero_up_to; raw += 997) {
        ASSERT_TRUE(s3_terms_zero(raw)) << raw;
        if (raw <= k.s2_terms_zero_up_to) {
            ASSERT_TRUE(s2_terms_zero(raw)) << raw;
        }
    }
    // Where they are: about where s^3 / 720 and s^2 / 24 reach half an ulp (2^-33), s = |w dt/2|^2
    // (s^2 is a whole number of ulps, 11 at the threshold, so the edge is coarse).
    const double s3_edge = std::cbrt(720.0 / 8589934592.0), s2_edge = std::sqrt(24.0 / 8589934592.0);
    EXPECT_NEAR(d(Fixed::from_raw(k.s3_terms_zero_up_to)), s3_edge, 0.03 * s3_edge);
    EXPECT_NEAR(d(Fixed::from_raw(k.s2_terms_zero_up_to)), s2_edge, 0.03 * s2_edge);
}

// One step of integrated() against the exact exponential map (cos|a|, sin|a| a/|a|) times q,
// computed in long double, from grid orientations, over half angles |a| from 1e-7 to 1 rad.
// The error in 2^-30 grid steps is the rounding (at most 2 steps) plus the series' own
// truncation after s^3 (below s^4 / 8! in each component); a series cut one power of s short
// (s^3 left out, error s^3 / 720: 1,500 grid steps at s = 0.1) fails it.
TEST(Quat, IntegratedMatchesTheExactMapWithinTheGrid) {
    std::mt19937_64 rng(2019);
    std::uniform_real_distribution<double> u(-1, 1);
    const long double grid = 1.0L / 1073741824.0L;
    const Fixed dt = Fixed::ratio(1, 60);
    double worst_small = 0;  // s <= 3.5e-3 (|w| below 7 rad/s at 60 Hz): the truncation is < 2^-34
    for (int i = 0; i < 200000; ++i) {
        const Quat q = normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))});
        const double mag = std::pow(10.0, -7 + 7 * (u(rng) + 1) / 2);  // |a|, 1e-7 to 1 rad
        const Vec3 dir{fx(u(rng)), fx(u(rng)), fx(u(rng))};
        const long double dl = std::sqrt((long double)d(dir.x) * d(dir.x) + (long double)d(dir.y) * d(dir.y) +
                                         (long double)d(dir.z) * d(dir.z));
        if (dl < 0.1L) continue;
        const Vec3 w{fx(d(dir.x) / dl * mag * 120), fx(d(dir.y) / dl * mag * 120), fx(d(dir.z) / dl * mag * 120)};
        const Vec3 a = w * Fixed::from_raw(dt.raw / 2);  // the half angle integrated() turns by
        const long double ax = d(a.x), ay = d(a.y), az = d(a.z);
        const long double s = ax * ax + ay * ay + az * az;
        if (s > 1 || s == 0) continue;
        const long double len = std::sqrt(s), c = std::cos(len), k = std::sin(len) / len;
        const long double pw = c, px = k * ax, py = k * ay, pz = k * az;
        const long double qw = d(q.w), qx = d(q.x), qy = d(q.y), qz = d(q.z);
        long double e[4] = {pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw};
        const long double n = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3]);
        const Quat got = integrated(q, w, dt);
        const Fixed g[4] = {got.w, got.x, got.y, got.z};
        long double err = 0;
        for (int j = 0; j < 4; ++j) err = std::max(err, std::fabs(d(g[j]) - e[j] / n) / grid);
        const long double truncation = s * s * s * s / 40320 / grid;
        ASSERT_LE(err, 2 + truncation) << i << " s=" << static_cast<double>(s);
        if (s <= 3.5e-3L) worst_small = std::max(worst_small, static_cast<double>(err));
    }
    EXPECT_LE(worst_small, 2.0);
    std::printf("worst error for s <= 3.5e-3: %.3f grid steps\n", worst_small);
}

TEST(Quat, CrossIsRightHanded) {
    const Vec3 x{Fixed::one(), Fixed::zero(), Fixed::zero()}, y{Fixed::zero(), Fixed::one(), Fixed::zero()};
    EXPECT_EQ(cross(x, y), (Vec3{Fixed::zero(), Fixed::zero(), Fixed::one()}));
}

}  // namespace
}  // namespace lockroll::sim
