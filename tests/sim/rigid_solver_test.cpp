// sim/rigid_solver.h through the World: rolling from friction, torque-free precession, snapshots
// of rotating state, damping, and that a particle scene is untouched by the rigid path.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "sim/snapshot.h"
#include "sim/rigid_solver.h"
#include "sim/world.h"
#include "tests/sim/scene_parts.h"

namespace lockroll::sim {
namespace {

using test::d;
using test::fx;
using test::v3;

SceneDesc floor_scene(const char* mu) {
    SceneDesc s = test::rigid_floor("100");
    for (auto& row : s.rigid.friction)
        for (auto& f : row) f = fx(mu);
    for (auto& row : s.rigid.static_friction)
        for (auto& f : row) f = fx(mu);
    return s;
}

BodyDesc ball(const char* vx, const char* wz) {
    BodyDesc b = test::ball(v3("0", "0.5", "0"));
    b.velocity = v3(vx, "0", "0");
    b.angular_velocity = v3("0", "0", wz);
    return b;
}

// Saves `a`, loads the bytes into a fresh world of scene s, and checks both step the same 60
// frames bit for bit; returns the snapshot.
std::vector<std::uint8_t> expect_replays_bit_for_bit(const SceneDesc& s, World& a) {
    std::vector<std::uint8_t> snap(snapshot_size(a));
    save(a, snap);
    World b(s);
    EXPECT_EQ(load(b, snap), "");
    EXPECT_EQ(checksum(a), checksum(b));
    for (int f = 0; f < 60; ++f) {
        a.step({});
        b.step({});
        EXPECT_EQ(checksum(a), checksum(b)) << "frame " << f;
    }
    return snap;
}

// A shortcut and the general arithmetic: the same value and the same overflow events.
template <class S, class G>
bool same_bits(S shortcut, G general) {
    const std::uint64_t start = overflow_events();
    const auto got = shortcut();
    const std::uint64_t got_events = overflow_events() - start;
    const std::uint64_t middle = overflow_events();
    const auto want = general();
    return got == want && got_events == overflow_events() - middle;
}

// A value of every magnitude (its bit length uniform), both signs, and the extremes.
Fixed any_magnitude(std::mt19937_64& rng) {
    const int bits = static_cast<int>(rng() % 66);
    if (bits == 64) return Fixed::min();
    if (bits == 65) return Fixed::max();
    const std::uint64_t r = bits == 63 ? rng() : rng() >> (63 - bits);
    return Fixed::from_raw(static_cast<std::int64_t>(r));
}

// The contact setup takes an axis normal's tangent basis (and the tangents' axis codes) from a
// table (rigid_detail::axis_tangents), and a sphere's arms on a wall without products by 0 and
// +-1 (scaled_axis, dot_axis): each must be exactly what the general arithmetic gives, bits and
// overflow counts, for each of the six axes and values of every magnitude.
TEST(RigidSolver, AxisShortcutsGiveTheGeneralBits) {
    std::mt19937_64 rng(1919);
    const auto raw = [&] { return any_magnitude(rng); };
    const Fixed one = Fixed::one(), z = Fixed::zero();
    const Vec3 axes[6] = {{one, z, z}, {z, one, z}, {z, z, one}, {-one, z, z}, {z, -one, z}, {z, z, -one}};
    for (const Vec3& n : axes) {
        const std::int8_t code = rigid_detail::axis_code(n);
        ASSERT_NE(code, 0);
        Vec3 t1, t2, g1, g2;
        std::int8_t c1 = 0, c2 = 0;
        rigid_detail::axis_tangents(code, t1, t2, c1, c2);
        rigid_detail::tangents(n, g1, g2);
        EXPECT_EQ(t1, g1);
        EXPECT_EQ(t2, g2);
        EXPECT_EQ(c1, rigid_detail::axis_code(g1));
        EXPECT_EQ(c2, rigid_detail::axis_code(g2));
        EXPECT_NE(c1, 0);  // a wall's tangents are axes too
        EXPECT_NE(c2, 0);
        // A sphere's arms on a wall: e * s and e . v without the products, for every magnitude
        // (the extremes included: -1 * INT64_MIN saturates and counts, as -INT64_MIN does).
        for (int i = 0; i < 200000; ++i) {
            const Fixed s = raw();
            const Vec3 v{raw(), raw(), raw()};
            ASSERT_TRUE(same_bits([&] { return rigid_detail::scaled_axis(code, s); }, [&] { return n * s; })) << i;
            ASSERT_TRUE(same_bits([&] { return rigid_detail::dot_axis(code, v); }, [&] { return dot(n, v); })) << i;
            // A box's arms on a wall: r x e without the products.
            ASSERT_TRUE(same_bits([&] { return rigid_detail::cross_axis(v, code); }, [&] { return cross(v, n); })) << i;
            // A product by an exact zero is an exact zero and counts nothing (make_row skips it).
            const std::uint64_t before = overflow_events();
            ASSERT_EQ(s * Fixed::zero(), Fixed::zero());
            ASSERT_EQ(overflow_events(), before);
        }
    }
    // Not an axis: code 0, whatever the near miss.
    EXPECT_EQ(rigid_detail::axis_code({one, Fixed::from_raw(1), z}), 0);
    EXPECT_EQ(rigid_detail::axis_code({Fixed::from_raw(Fixed::kOne - 1), z, z}), 0);
    EXPECT_EQ(rigid_detail::axis_code({Fixed::from_raw(2 * Fixed::kOne), z, z}), 0);
}

// The contact setup's effective masses (make_row) take 1/k through a memo of the last two k
// (rigid_detail::ReciprocalMemo): it must give reciprocal()'s bits and overflow counts, on k
// drawn from a small pool (so most are repeats) that holds k whose reciprocal saturates and
// counts (raw 1 and 2), k at the memo's least and just below it, and k of every size.
TEST(RigidSolver, ReciprocalMemoGivesTheGeneralBits) {
    std::mt19937_64 rng(2020);
    const std::int64_t least = rigid_detail::ReciprocalMemo::kLeast;
    std::vector<Fixed> pool = {Fixed::from_raw(1), Fixed::from_raw(2), Fixed::from_raw(least), Fixed::from_raw(least - 1),
                               Fixed::one(), Fixed::from_int(2), Fixed::max()};
    for (int i = 0; i < 9; ++i) pool.push_back(Fixed::from_raw(static_cast<std::int64_t>(rng() >> (1 + rng() % 63)) + 1));
    rigid_detail::ReciprocalMemo memo;
    int saturating = 0;
    for (int i = 0; i < 100000; ++i) {
        const Fixed k = pool[rng() % pool.size()];
        saturating += k.raw <= 2;
        ASSERT_TRUE(same_bits([&] { return memo.reciprocal_of(k); }, [&] { return reciprocal(k); })) << i << " k " << k.raw;
    }
    EXPECT_GT(saturating, 1000);
}

// The friction clamp's zero cone (rigid_detail::clamp_to_cone with pn = 0, a contact that let
// go) skips the square root and the division: the same bits and overflow count as the general
// clamp, for friction of every magnitude (|t|^2 near 2^127, where |t|'s raw value wraps) and
// any coefficients (and, half the time, any pn: the rest of the clamp).
TEST(RigidSolver, ZeroConeClampIsTheGeneralClamp) {
    std::mt19937_64 rng(2121);
    const auto raw = [&] { return any_magnitude(rng); };
    for (int i = 0; i < 200000; ++i) {
        Fixed t1 = raw(), t2 = raw();
        if (i % 7 == 0) t1 = Fixed::zero();
        if (i % 11 == 0) t2 = Fixed::zero();
        if (i % 13 == 0) t1 = Fixed::min();
        const Fixed mu_s = raw(), mu_k = raw(), pn = i % 2 == 0 ? Fixed::zero() : raw();  // half the general way
        // The clamp without the shortcut (what solve_one() took before it).
        std::uint64_t start = overflow_events();
        Fixed g1 = t1, g2 = t2;
        rigid_detail::clamp_to_cone_general(g1, g2, pn, mu_s, mu_k);
        const std::uint64_t general = overflow_events() - start;
        start = overflow_events();
        Fixed s1 = t1, s2 = t2;
        rigid_detail::clamp_to_cone(s1, s2, pn, mu_s, mu_k);
        const std::uint64_t shortcut = overflow_events() - start;
        ASSERT_EQ(g1, s1) << i;
        ASSERT_EQ(g2, s2) << i;
        ASSERT_EQ(general, shortcut) << i;
    }
}

// Equal masses (every dynamic pair of the piles): apply_normal() and apply_friction() take the
// velocity change both bodies get once (rigid_detail::shared_change), which must note any
// overflow event of it twice, as one computation per body does. Values of every magnitude, so
// products saturate. And a body at rest adds exactly zero to a row speed (row_speed() takes its
// arm term without testing w): dot_wide(c, 0) is 0 with nothing noted, for every c.
TEST(RigidSolver, EqualMassChangeCountsEachBodysOverflows) {
    std::mt19937_64 rng(2020);
    const auto raw = [&] { return any_magnitude(rng); };
    const auto vec = [&] { return Vec3{raw(), raw(), raw()}; };
    int saturating = 0;
    for (int i = 0; i < 200000; ++i) {
        const Vec3 d = vec(), e = vec(), va = vec(), vb = vec();
        const Fixed l = raw(), k = raw(), m = raw();
        // A normal impulse's change d (l m), and a friction impulse's d (l m) + e (k m).
        const auto normal = [&] { return d * (l * m); };
        const auto friction = [&] { return d * (l * m) + e * (k * m); };
        const auto check = [&](auto change) {
            std::uint64_t start = overflow_events();
            const Vec3 ga = va - change(), gb = vb + change();  // each body its own
            const std::uint64_t general = overflow_events() - start;
            start = overflow_events();
            const Vec3 dv = rigid_detail::shared_change(change);
            const Vec3 sa = va - dv, sb = vb + dv;
            const std::uint64_t shared = overflow_events() - start;
            // Only the change's own events are repeated (each body's sum notes its own).
            start = overflow_events();
            (void)change();
            if (overflow_events() != start) ++saturating;
            return ga == sa && gb == sb && general == shared;
        };
        ASSERT_TRUE(check(normal)) << i;
        ASSERT_TRUE(check(friction)) << i;
        const std::uint64_t before = overflow_events();
        ASSERT_EQ(dot_wide(d, Vec3{}), i128{0});
        ASSERT_EQ(overflow_events(), before);
    }
    EXPECT_GT(saturating, 10000);  // the repeat was exercised
}

TEST(RigidSolver, SlidingBallEndsRollingAtFiveSevenths) {
    SceneDesc s = floor_scene("0.3");
    s.bodies.push_back(ball("5", "0"));
    World w(s);
    for (int i = 0; i < 120; ++i) w.step({});
    EXPECT_NEAR(d(w.velocity(1).x), 5.0 * 5 / 7, 1e-3);
    // Rolling without slipping: v = -w_z r.
    EXPECT_NEAR(d(w.velocity(1).x), -d(w.angular_velocity(1).z) * 0.5, 1e-4);
    EXPECT_NEAR(d(w.position(1).y), 0.5, 0.006);  // resting on the floor within slop
}

TEST(RigidSolver, BackspinBallComesBack) {
    SceneDesc s = floor_scene("0.3");
    // 2 w0 r = 2 * 30 * 0.5 = 30 > 5 v0 = 10: it returns at (5 v0 - 2 w0 r) / 7 = -20/7 m/s.
    s.bodies.push_back(ball("2", "30"));  // w_z > 0 spins its bottom forward: backspin for +x motion
    World w(s);
    for (int i = 0; i < 240; ++i) w.step({});
    EXPECT_NEAR(d(w.velocity(1).x), -20.0 / 7, 2e-3);
}

// One asymmetric box turning freely (no gravity, no floor).
SceneDesc free_box_scene() {
    SceneDesc s;
    s.rigid.enabled = true;
    s.gravity = {};
    BodyDesc b;
    b.shape = Shape::Box;
    b.mass = fx("1");
    b.half_extents = v3("0.5", "0.3", "0.1");
    b.angular_velocity = v3("0.1", "3", "0.2");
    s.bodies.push_back(b);
    return s;
}

TEST(RigidSolver, FreeBoxKeepsAngularMomentum) {
    const SceneDesc s = free_box_scene();
    const BodyDesc& b = s.bodies[0];
    World w(s);
    auto momentum = [&] {
        const Mat3 r = rotation(w.orientation(0));
        const Vec3 wb = transpose_times(r, w.angular_velocity(0));
        const double i[3] = {(0.09 + 0.01) / 3, (0.25 + 0.01) / 3, (0.25 + 0.09) / 3};
        const Vec3 lb{Fixed::from_raw(std::llround(d(wb.x) * i[0] * 4294967296.0)),
                      Fixed::from_raw(std::llround(d(wb.y) * i[1] * 4294967296.0)),
                      Fixed::from_raw(std::llround(d(wb.z) * i[2] * 4294967296.0))};
        const Vec3 l = r * lb;
        return std::vector<double>{d(l.x), d(l.y), d(l.z)};
    };
    const auto l0 = momentum();
    for (int i = 0; i < 600; ++i) w.step({});
    const auto l1 = momentum();
    const double n0 = std::sqrt(l0[0] * l0[0] + l0[1] * l0[1] + l0[2] * l0[2]);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(l1[k], l0[k], 1e-4 * n0);
    // And it precesses: the angular velocity is not constant for this asymmetric box.
    EXPECT_NE(w.angular_velocity(0), b.angular_velocity);
}

// A sphere's contact point lies on the normal through its centre, so without friction no
// contact can turn it. The solver takes that arm exactly; computed as (point - centre) x n it
// was a rounding residue that set frictionless spheres spinning by ~1e-10 rad/s.
TEST(RigidSolver, FrictionlessSpheresNeverSpin) {
    SceneDesc s = floor_scene("0");
    s.bodies[0].orientation = Quat{fx("0.9659258262890683"), fx("0.2588190451025208"), Fixed::zero(), Fixed::zero()};  // 30 deg about x
    BodyDesc a = ball("3", "0");
    a.position = v3("-2", "3", "0.3");
    a.velocity = v3("3", "-1", "0.4");
    BodyDesc b = ball("0", "0");
    b.position = v3("0", "2.9", "0.55");
    b.velocity = v3("-0.5", "0", "0.1");
    s.bodies.push_back(a);
    s.bodies.push_back(b);
    World w(s);
    for (int i = 0; i < 180; ++i) {
        w.step({});
        ASSERT_EQ(w.angular_velocity(1), Vec3{}) << "frame " << i;
        ASSERT_EQ(w.angular_velocity(2), Vec3{}) << "frame " << i;
    }
    // They did meet each other and the tilted floor (their velocities changed direction).
    EXPECT_LT(d(w.velocity(1).x), 2.5);
    EXPECT_GT(d(w.velocity(2).x) - (-0.5), 0.1);
}

// Restitution (the default table: sphere-box e = 0.8, threshold 0.5 m/s). These three failed
// before the 2026-12-03 fix, which let a 10k pile hop forever (docs/physics.md, "Piles that
// come to rest").

// A bounce is e times the approach speed the ball came in with, not counting the g dt this
// step adds: 0.8 * 2 = 1.6 m/s, where bouncing gravity too gave 0.8 * (2 + 9.81/60) = 1.73.
TEST(RigidSolver, BounceIsEOfTheApproachBeforeThisStepsGravity) {
    SceneDesc s = floor_scene("0.3");
    BodyDesc b = ball("0", "0");
    b.velocity = v3("0", "-2", "0");  // touching the floor (gap 0), falling at 2 m/s
    s.bodies.push_back(b);
    World w(s);
    w.step({});
    EXPECT_NEAR(d(w.velocity(1).y), 0.8 * 2, 1e-6);
}

// A speculative point (a gap within the contact margin) bounces only if the approach closes
// the gap within this step: 2.5 cm above the floor at 1.16 m/s it still falls freely. (The
// pair's margin is 1 cm + 1.16 m/s dt = 2.9 cm: RigidSolver::pair_margin().)
TEST(RigidSolver, SpeculativePointBouncesOnlyWhenTheGapCloses) {
    SceneDesc s = floor_scene("0.3");
    BodyDesc b = ball("0", "0");
    b.position = v3("0", "0.525", "0");
    b.velocity = v3("0", "-1", "0");
    s.bodies.push_back(b);
    World w(s);
    w.step({});
    const double v = -1 - 9.81 / 60;
    EXPECT_NEAR(d(w.velocity(1).y), v, 1e-6);
    EXPECT_NEAR(d(w.position(1).y), 0.525 + v / 60, 1e-6);
    ASSERT_EQ(w.rigid_solver().contact_count(), 1u);  // the point was there: it just did not bounce
}

// No gravity and a static wall 2 mm thick in the plane x = 0 (body 0), plus `body` (body 1).
SceneDesc wall_and(const BodyDesc& body) {
    SceneDesc s;
    s.rigid.enabled = true;
    s.gravity = Vec3{};
    BodyDesc wall;
    wall.shape = Shape::Box;
    wall.half_extents = v3("0.001", "2", "2");
    s.bodies.push_back(wall);
    s.bodies.push_back(body);
    return s;
}

// A pair's speculative margin grows with how fast it closes: a 1 cm ball at 2.5 m/s moves
// 4.2 cm a step toward a 2 mm wall, and the step before it would pass the wall clean through
// its gap is 2.5 cm, beyond the 1 cm base. The velocity term (1 cm + 4.2 cm, capped at the
// 5 cm contact margin) gives it the point that stops it; a margin of the base alone (or 1 mm)
// lets it through. A gap of 4.5 cm is beyond a resting pair's margin: no point.
TEST(RigidSolver, SpeculativeMarginGrowsWithTheClosingSpeed) {
    BodyDesc b;
    b.shape = Shape::Sphere;
    b.radius = fx("0.005");
    b.mass = fx("1");
    b.position = v3("-0.2393333", "0", "0");  // the gap is 2.5 cm after 5 steps
    b.velocity = v3("2.5", "0", "0");
    const SceneDesc s = wall_and(b);
    World w(s);
    for (int f = 0; f < 30; ++f) {
        w.step({});
        ASSERT_LT(d(w.position(1).x), -0.001) << "frame " << f;
    }
    // At rest relative to the wall, 4.5 cm away: beyond 1 cm, so no point.
    SceneDesc r = s;
    r.bodies[1].position = v3("-0.051", "0", "0");
    r.bodies[1].velocity = Vec3{};
    World still(r);
    still.step({});
    EXPECT_EQ(still.rigid_solver().contact_count(), 0u);
}

// A turn counts too: a 1 m plank 2.5 cm from a wall, turning at 4 rad/s so that its end
// comes at 2 m/s (3.3 cm a step), gets its speculative point (margin 1 cm + 4 rad/s x 0.5 m
// half diagonal x dt = 4.3 cm); with the turn left out of the bound it got none.
TEST(RigidSolver, SpeculativeMarginCountsATurn) {
    BodyDesc plank;
    plank.shape = Shape::Box;
    plank.half_extents = v3("0.01", "0.5", "0.01");
    plank.mass = fx("1");
    plank.position = v3("-0.036", "0", "0");  // its face 2.5 cm from the wall's
    plank.angular_velocity = v3("0", "0", "-4");  // the upper end turns toward +x
    SceneDesc s = wall_and(plank);
    World w(s);
    w.step({});
    EXPECT_GT(w.rigid_solver().contact_count(), 0u);
    // Not turning, the same plank gets none (the gap is beyond the 1 cm base).
    s.bodies[1].angular_velocity = Vec3{};
    World still(s);
    still.step({});
    EXPECT_EQ(still.rigid_solver().contact_count(), 0u);
}

// The per-body closing bound is the Fixed expression (|v|_1 + |w|_1 reach) dt bit for bit below
// the cap, and takes the cap for any speed above it without counting an overflow event (the
// Fixed expression saturated its sums and product on absurd spins, and counted them).
TEST(RigidSolver, ClosingBoundIsExactAndNeverOverflows) {
    const Fixed dt = Fixed::ratio(1, 60), margin = fx("0.05"), cap = margin * Fixed::from_int(60);  // as configure()
    std::mt19937_64 rng(19);
    const auto any = [&](std::int64_t range) {
        return Fixed::from_raw(static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(2 * range + 1)) - range);
    };
    const std::uint64_t before = overflow_events();
    for (int i = 0; i < 20000; ++i) {
        const std::int64_t range = (i % 2 == 0 ? Fixed::kOne : 4 * Fixed::kOne);  // below and across the cap
        const Vec3 v{any(range), any(range), any(range)}, w{any(8 * range), any(8 * range), any(8 * range)};
        const Fixed reach = Fixed::from_raw(static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(Fixed::kOne / 2)));
        const Fixed speed = abs(v.x) + abs(v.y) + abs(v.z) + (abs(w.x) + abs(w.y) + abs(w.z)) * reach;
        const Fixed expected = speed > cap ? margin : speed * dt;
        ASSERT_EQ(RigidSolver::closing_bound(v, w, reach, cap, margin, dt).raw, expected.raw) << "case " << i;
    }
    ASSERT_EQ(overflow_events(), before);  // ordinary speeds: the reference never saturated
    const Fixed big = Fixed::max(), small = Fixed::min();
    EXPECT_EQ(RigidSolver::closing_bound({big, small, big}, {}, Fixed::zero(), cap, margin, dt).raw, margin.raw);
    EXPECT_EQ(RigidSolver::closing_bound({}, {big, small, big}, fx("0.25"), cap, margin, dt).raw, margin.raw);
    EXPECT_EQ(RigidSolver::closing_bound({}, {fx("1000000"), Fixed::zero(), Fixed::zero()}, fx("100000"), cap, margin, dt).raw,
              margin.raw);
    EXPECT_EQ(overflow_events(), before);
}

// Dropped from 30 cm on e = 0.8, a ball's rebound speeds fall by e each bounce until they are
// below the threshold, and then it rests. (Before the fix each bounce gained e g dt and the
// ball settled into a hop of about 0.9 m/s, above the threshold, that never ended.)
TEST(RigidSolver, BallOnABouncyFloorComesToRest) {
    SceneDesc s = floor_scene("0.3");
    BodyDesc b = ball("0", "0");
    b.position = v3("0", "0.8", "0");
    s.bodies.push_back(b);
    World w(s);
    std::vector<double> rebounds;
    double prev = 0;
    for (int f = 0; f < 240; ++f) {
        w.step({});
        const double vy = d(w.velocity(1).y);
        if (prev < 0 && vy > 0) rebounds.push_back(vy);
        prev = vy;
    }
    ASSERT_GE(rebounds.size(), 4u);
    // The frame grid: a ball comes back to the floor with its rebound speed give or take up to
    // g dt (which frame the contact falls on), and bounces e times that.
    for (std::size_t i = 1; i < rebounds.size(); ++i)
        EXPECT_LE(rebounds[i], 0.8 * (rebounds[i - 1] + 9.81 / 60)) << "bounce " << i;
    EXPECT_LT(rebounds.back(), 0.8);  // the last bounce was near the threshold
    EXPECT_LT(std::abs(d(w.velocity(1).y)), 0.01);
    EXPECT_NEAR(d(w.position(1).y), 0.5, 0.006);  // resting on the floor within slop
}

TEST(RigidSolver, DampingSlowsFreeBodies) {
    SceneDesc s;
    s.rigid.enabled = true;
    s.gravity = {};
    s.rigid.linear_damping = fx("1");
    BodyDesc b = ball("1", "2");
    b.angular_damping = fx("0.5");
    s.bodies.push_back(b);
    World w(s);
    for (int i = 0; i < 60; ++i) w.step({});
    // v_n = v0 / (1 + c dt)^n: after 1 s, about e^-c.
    EXPECT_NEAR(d(w.velocity(0).x), std::pow(1.0 / (1 + 1.0 / 60), 60), 1e-6);
    EXPECT_NEAR(d(w.angular_velocity(0).z), 2 * std::pow(1.0 / (1 + 0.5 / 60), 60), 1e-6);
}

TEST(RigidSolver, SnapshotHoldsRotationAndReplaysBitForBit) {
    SceneDesc s = floor_scene("0.5");
    for (int i = 0; i < 6; ++i) {
        BodyDesc b;
        b.shape = i % 3 == 0 ? Shape::Box : i % 3 == 1 ? Shape::Capsule : Shape::Sphere;
        b.mass = fx("1");
        b.radius = fx("0.3");
        b.half_height = fx("0.4");
        b.half_extents = v3("0.3", "0.2", "0.4");
        b.position = {Fixed::from_int(i * 2 - 5), fx("1.5"), fx("0")};
        b.velocity = v3("0.5", "0", "-0.3");
        b.angular_velocity = v3("1", "2", "-1");
        s.bodies.push_back(b);
    }
    World a(s);
    EXPECT_EQ(snapshot_size(a), 24u + 88u * 6u);
    for (int f = 0; f < 30; ++f) a.step({});
    const std::vector<std::uint8_t> snap = expect_replays_bit_for_bit(s, a);
    EXPECT_TRUE(a.rigid_solver().contact_count() > 0);
    // Orientation is part of the state: a flipped bit shows up as that field.
    World c(s);
    ASSERT_EQ(load(c, snap), "");
    c.flip_bit(3, 8, 5);  // orientation.y of body 3 (dynamic index 2)
    std::vector<std::uint8_t> snap_c(snapshot_size(c));
    save(c, snap_c);
    int field = -2;
    EXPECT_EQ(first_difference(snap, snap_c, &field), 2);
    EXPECT_STREQ(kBodyFieldNames[field], "orientation.y");
    World unflipped(s);
    ASSERT_EQ(load(unflipped, snap), "");
    EXPECT_NE(body_hash(c, 3), body_hash(unflipped, 3));
    EXPECT_EQ(body_hash(c, 1), body_hash(unflipped, 1));
}

TEST(RigidSolver, ParticleSnapshotRefusedByARigidWorld) {
    SceneDesc s = floor_scene("0.5");
    s.bodies.push_back(ball("1", "0"));
    SceneDesc p = s;
    p.rigid.enabled = false;
    p.bodies[1].angular_velocity = {};
    World rigid(s), particle(p);
    std::vector<std::uint8_t> snap(snapshot_size(particle));
    save(particle, snap);
    EXPECT_NE(load(rigid, snap).find("layout"), std::string::npos);
}


// A short warm-started stack: boxes on the floor and on each other.
SceneDesc warm_stack(int boxes) {
    SceneDesc s = floor_scene("0.5");
    s.iterations = 8;
    s.rigid.warm_starting = true;
    for (int i = 0; i < boxes; ++i) {
        BodyDesc b;
        b.shape = Shape::Box;
        b.mass = fx("1");
        b.half_extents = v3("0.5", "0.5", "0.5");
        b.position = {fx("0"), Fixed::from_int(i) + fx("0.5"), fx("0")};
        s.bodies.push_back(b);
    }
    return s;
}

TEST(RigidSolver, WarmStartingCarriesImpulsesThroughSnapshots) {
    const SceneDesc s = warm_stack(4);
    World a(s);
    EXPECT_EQ(snapshot_size(a), 24u + 88u * 4u + 4u);  // no impulses yet
    EXPECT_EQ(snapshot_capacity(a), 24u + 88u * 4u + 4u + 33u * 8u * 4u);
    for (int f = 0; f < 30; ++f) a.step({});
    // At least four face points under every box, each carried, keyed by the pair's dynamic
    // body first (the floor is static), in key order.
    const auto& carried = a.contact_impulses();
    ASSERT_GE(carried.size(), 16u);
    EXPECT_EQ(carried[0].body, 1u);
    EXPECT_EQ(carried[0].other, 0u);  // the static floor
    EXPECT_TRUE(std::is_sorted(carried.begin(), carried.end(), key_less));
    // The bottom box carries the weight of four: 4 m g dt over its points on the floor.
    Fixed bottom;
    for (const ContactImpulse& c : carried)
        if (c.body == 1 && c.other == 0) bottom += c.pn;
    EXPECT_NEAR(d(bottom), 4 * 9.81 / 60, 0.065);  // within 10 %: still settling after 0.5 s
    EXPECT_EQ(snapshot_size(a), 24u + 88u * 4u + 4u + 33u * carried.size());

    const std::vector<std::uint8_t> snap = expect_replays_bit_for_bit(s, a);
    // Without the impulses the same bodies step differently: they are state.
    World c(s);
    ASSERT_EQ(load(c, snap), "");
    World cold(s);
    std::vector<std::uint8_t> no_impulses(snap.begin(), snap.begin() + 24 + 88 * 4 + 4);
    no_impulses[24 + 88 * 4] = 0;
    ASSERT_EQ(load(cold, no_impulses), "");
    c.step({});
    cold.step({});
    EXPECT_NE(checksum(c), checksum(cold));
}

TEST(RigidSolver, WarmStartImpulsesNarrowToTheirBody) {
    const SceneDesc s = warm_stack(3);
    World a(s);
    for (int f = 0; f < 20; ++f) a.step({});
    std::vector<std::uint8_t> snap(snapshot_size(a)), other(snapshot_size(a));
    save(a, snap);
    other = snap;
    // Box 2's first impulse (box 1's come first: on the floor and under box 2), a bit of its pn.
    const auto& carried = a.contact_impulses();
    const auto box2 = std::find_if(carried.begin(), carried.end(), [](const ContactImpulse& c) { return c.body == 2; });
    ASSERT_NE(box2, carried.end());
    const std::size_t entry = 24 + 88 * 3 + 4 + 33 * static_cast<std::size_t>(box2 - carried.begin());
    ASSERT_EQ(snap[entry], 2u);
    other[entry + 9] ^= 1;
    int field = 0;
    EXPECT_EQ(first_difference(snap, other, &field), 3);  // past the bodies
    EXPECT_EQ(field, -1);
    EXPECT_EQ(snapshot_body_hash(a, snap, 1), body_hash(a, 2));
    EXPECT_EQ(snapshot_body_hash(a, snap, 0), snapshot_body_hash(a, other, 0));
    EXPECT_NE(snapshot_body_hash(a, snap, 1), snapshot_body_hash(a, other, 1));
    EXPECT_EQ(snapshot_body_hash(a, snap, 2), snapshot_body_hash(a, other, 2));
}

TEST(RigidSolver, WarmStartSnapshotsAreValidatedBeforeLoading) {
    const SceneDesc s = warm_stack(3);
    World a(s);
    for (int f = 0; f < 20; ++f) a.step({});
    std::vector<std::uint8_t> snap(snapshot_size(a));
    save(a, snap);
    const std::uint64_t before = checksum(a);
    const std::size_t first = 24 + 88 * 3 + 4;
    auto broken = [&](auto&& edit) {
        std::vector<std::uint8_t> bad = snap;
        edit(bad);
        return load(a, bad);
    };
    EXPECT_NE(broken([&](auto& b) { b[first + 33 + 8] = 0; }).find("out of key order"), std::string::npos);
    EXPECT_NE(broken([&](auto& b) { b[first] = 0; }).find("not a dynamic body"), std::string::npos);  // the floor
    EXPECT_NE(broken([&](auto& b) { b[first - 4] = 200; }).find("more than the world's"), std::string::npos);
    EXPECT_NE(broken([&](auto& b) { b.pop_back(); }).find("bytes, expected"), std::string::npos);
    EXPECT_EQ(checksum(a), before);  // every refusal left the world as it was
    // A world without warm starting refuses layout 2 and says why.
    SceneDesc plain = s;
    plain.rigid.warm_starting = false;
    World p(plain);
    EXPECT_NE(load(p, snap).find("layout is 2"), std::string::npos);
}


// A dynamic unit cube of 1 kg centred at (0, y, 0).
BodyDesc cube(const char* y) { return test::box(v3("0", y, "0"), v3("0.5", "0.5", "0.5")); }

// A unit box on the floor sunk 1 cm into it, or resting on an equal static box yawed by about
// 1.15 degrees (the two faces clip to an octagon of eight points).
SceneDesc sunk_box(bool split) {
    SceneDesc s = floor_scene("0.5");
    s.rigid.split_impulse = split;
    s.iterations = 16;
    s.rigid.baumgarte = Fixed::one();
    s.rigid.slop = Fixed::zero();
    s.bodies.push_back(cube("0.49"));
    return s;
}

SceneDesc yawed_on_pedestal(bool reduce) {
    SceneDesc s = floor_scene("0.5");
    s.rigid.warm_starting = true;
    s.rigid.reduce_manifold = reduce;
    BodyDesc base = cube("0.5");
    base.mass = Fixed::zero();  // static
    s.bodies.push_back(base);
    BodyDesc top = cube("1.5");
    top.orientation = {fx("0.99995"), Fixed::zero(), fx("0.0099998"), Fixed::zero()};  // about y
    s.bodies.push_back(top);
    return s;
}

TEST(RigidSolver, SplitImpulsePushesOutWithoutVelocity) {
    World split(sunk_box(true)), plain(sunk_box(false));
    split.step({});
    plain.step({});
    // Baumgarte 1, slop 0: both push the whole centimetre out in one step...
    EXPECT_NEAR(d(split.position(1).y), 0.5, 2e-4);
    EXPECT_NEAR(d(plain.position(1).y), 0.5, 2e-4);
    // ...but only the plain solver leaves the push in the velocity (0.01 m * 60 Hz).
    EXPECT_NEAR(d(plain.velocity(1).y), 0.6, 0.01);
    EXPECT_NEAR(d(split.velocity(1).y), 0.0, 1e-3);
    // Resting afterwards: the pseudo velocities are dropped every step, not carried.
    for (int f = 0; f < 30; ++f) split.step({});
    EXPECT_NEAR(d(split.position(1).y), 0.5, 1e-4);
    EXPECT_NEAR(d(split.velocity(1).y), 0.0, 1e-3);
}

TEST(RigidSolver, ReducedManifoldKeepsFourCornersUnderStableIds) {
    World eight(yawed_on_pedestal(false)), four(yawed_on_pedestal(true));
    eight.step({});
    four.step({});
    EXPECT_EQ(eight.rigid_solver().contact_count(), 8u);  // the clipped octagon
    EXPECT_EQ(four.rigid_solver().contact_count(), 4u);
    for (int f = 0; f < 20; ++f) four.step({});
    std::vector<std::uint8_t> ids;
    for (const ContactImpulse& c : four.contact_impulses()) ids.push_back(c.feature);
    EXPECT_EQ(ids, (std::vector<std::uint8_t>{240, 241, 242, 243}));  // one per diagonal
    // The same keys step after step, so every point is warm started.
    for (int f = 0; f < 20; ++f) {
        four.step({});
        std::vector<std::uint8_t> now;
        for (const ContactImpulse& c : four.contact_impulses()) now.push_back(c.feature);
        EXPECT_EQ(now, ids) << "frame " << f;
    }
    // It stays on its pedestal, not turned.
    EXPECT_NEAR(d(four.position(2).y), 1.5, 1e-3);
    EXPECT_NEAR(d(four.position(2).x), 0.0, 1e-4);
}

TEST(RigidSolver, BlockSolverSharesABoxsLoadEvenly) {
    // One pass, no warm starting: point after point, the first corner takes the whole stop and
    // turns the box; solved as a block the four corners share it and the box does not turn.
    auto first_step_spin = [](bool block) {
        SceneDesc s = floor_scene("0.5");
        s.iterations = 1;
        s.rigid.block_solver = block;
        s.bodies.push_back(cube("0.5"));
        World w(s);
        w.step({});
        const Vec3 av = w.angular_velocity(1);
        return std::sqrt(d(av.x) * d(av.x) + d(av.y) * d(av.y) + d(av.z) * d(av.z));
    };
    EXPECT_GT(first_step_spin(false), 1e-2);
    EXPECT_LT(first_step_spin(true), 1e-5);
}

TEST(RigidSolver, StackSolverOptionsHoldATenBoxStackAndReplay) {
    SceneDesc s = warm_stack(10);
    s.iterations = 32;
    s.rigid.split_impulse = s.rigid.reduce_manifold = s.rigid.block_solver = true;
    s.rigid.baumgarte = Fixed::one();
    s.rigid.slop = Fixed::zero();
    World w(s);
    double drift = 0;
    for (int f = 0; f < 300; ++f) {
        w.step({});
        for (BodyId id = 1; id <= 10; ++id) {
            const double dx = d(w.position(id).x), dy = d(w.position(id).y) - (id - 0.5), dz = d(w.position(id).z);
            drift = std::max(drift, std::sqrt(dx * dx + dy * dy + dz * dz));
        }
    }
    EXPECT_LT(drift, 0.005);  // the first frames' sag
    EXPECT_NEAR(d(w.position(10).y), 9.5, 5e-4);  // recovered
    EXPECT_NEAR(d(w.position(10).x), 0.0, 1e-5);  // and not leaning
    // The pseudo velocities are per-step scratch: the snapshot (bodies + carried impulses)
    // is still the whole state.
    expect_replays_bit_for_bit(s, w);
}

// integrate() keeps each turning box's new rotation for the next step's update_inertia(),
// taken only when the orientation is still that quaternion. A rollback (snapshot load) to an
// earlier state must not reuse the rotations of the frames it undid: rolled back and stepped
// again, the world is bit for bit the one that never rolled back (with and without split
// impulses, whose pseudo motion turns the boxes after the rotation was kept).
TEST(RigidSolver, KeptRotationNeverOutlivesARollback) {
    for (const bool split : {false, true}) {
        SceneDesc s = floor_scene("0.5");
        s.rigid.split_impulse = split;
        for (int i = 0; i < 4; ++i) {
            BodyDesc b;
            b.shape = Shape::Box;
            b.mass = fx("1");
            b.half_extents = v3("0.3", "0.2", "0.4");
            b.position = {Fixed::from_int(i * 2 - 3), fx("0.5"), fx("0")};
            b.angular_velocity = v3("1", "2", "-1");
            s.bodies.push_back(b);
        }
        World straight(s), rolled(s);
        for (int f = 0; f < 30; ++f) {
            straight.step({});
            rolled.step({});
        }
        std::vector<std::uint8_t> snap(snapshot_size(rolled));
        save(rolled, snap);
        for (int f = 0; f < 30; ++f) rolled.step({});  // frames the rollback undoes
        ASSERT_EQ(load(rolled, snap), "");
        for (int f = 0; f < 30; ++f) {
            straight.step({});
            rolled.step({});
            ASSERT_EQ(checksum(straight), checksum(rolled)) << "split " << split << " frame " << f;
        }
        EXPECT_TRUE(rolled.rigid_solver().contact_count() > 0);
    }
}

// The same for one free box whose orientation is written between steps (a flipped bit): the
// next step must build the new orientation's rotation, as a world loaded with that state does.
TEST(RigidSolver, KeptRotationNeverOutlivesAWrittenOrientation) {
    const SceneDesc s = free_box_scene();
    World a(s);
    for (int f = 0; f < 10; ++f) a.step({});
    a.flip_bit(0, 8, 20);  // orientation.y
    std::vector<std::uint8_t> snap(snapshot_size(a));
    save(a, snap);
    World fresh(s);
    ASSERT_EQ(load(fresh, snap), "");
    for (int f = 0; f < 5; ++f) {
        a.step({});
        fresh.step({});
        ASSERT_EQ(checksum(a), checksum(fresh)) << "frame " << f;
    }
}

// The parallel step's phase 1 makes each manifold in place in a FoundList (find_manifolds()),
// whose storage keeps earlier steps' manifolds and the last one made without points. Only the
// manifolds with points of the last fill() are read: never one without points (the last one made
// included), never one past them from an earlier, longer fill.
TEST(RigidSolver, FoundListHoldsOnlyTheKeptManifolds) {
    rigid_detail::FoundList list;
    const auto fill = [&list](std::initializer_list<int> counts) {
        const std::vector<int> made(counts);
        list.fill(0, made.size(), [&made](std::size_t i, Manifold& m) { m.count = made[i]; });
        std::vector<std::pair<std::uint32_t, int>> seen;
        for (const rigid_detail::Found& f : list) seen.emplace_back(f.pair, f.m.count);
        EXPECT_EQ(list.size(), seen.size());
        return seen;
    };
    using Seen = std::vector<std::pair<std::uint32_t, int>>;
    EXPECT_EQ(fill({2, 0, 1, 3, 4, 0}), (Seen{{0, 2}, {2, 1}, {3, 3}, {4, 4}}));
    EXPECT_EQ(fill({0, 1, 0, 2, 0}), (Seen{{1, 1}, {3, 2}}));
    EXPECT_EQ(fill({0, 0}), Seen{});
    EXPECT_EQ(fill({4, 4, 4, 4, 4, 4, 4}), (Seen{{0, 4}, {1, 4}, {2, 4}, {3, 4}, {4, 4}, {5, 4}, {6, 4}}));
}

}  // namespace
}  // namespace lockroll::sim
