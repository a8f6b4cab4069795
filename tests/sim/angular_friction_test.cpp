// rigid.spinning_friction and rigid.rolling_friction (sim/rigid_solver_angular_friction.cpp;
// docs/physics.md "Spinning and rolling friction"): a ball spinning about the contact normal
// stops, a rolling ball slows, a small pile comes to rest and falls asleep whole, the bits are
// the same at any worker count (plain and graph-coloured), and bad coefficients are refused.
#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <vector>

#include "sim/scene.h"
#include "sim/snapshot.h"
#include "sim/world.h"
#include "tests/sim/scene_parts.h"

namespace lockroll::sim {
namespace {

using test::ball;
using test::fx;
using test::v3;

// A rigid scene without bounce on a static floor whose top face is y = 0.
SceneDesc floor_scene(const char* spin, const char* roll) {
    SceneDesc s = test::rigid_floor("50");
    s.rigid.spinning_friction = fx(spin);
    s.rigid.rolling_friction = fx(roll);
    test::no_bounce(s);
    return s;
}

// A 1 kg ball of radius 0.5 resting on the floor, spinning at 5 rad/s about the vertical.
// Spinning friction 0.02 m: torque 0.02 m * 9.81 N = 0.196 N m on I = 0.1 kg m^2, 1.96 rad/s^2,
// so it stops in about 2.55 s (153 frames).
World spinning_ball(const char* spin) {
    SceneDesc s = floor_scene(spin, "0");
    BodyDesc b = ball(v3("0", "0.5", "0"));
    b.angular_velocity = v3("0", "5", "0");
    s.bodies.push_back(b);
    return World(s);
}

TEST(AngularFriction, SpinningBallStopsWithSpinningFrictionAndKeepsSpinningWithout) {
    World on = spinning_ball("0.02"), off = spinning_ball("0");
    int stopped = -1;
    for (int f = 0; f < 300; ++f) {
        on.step({});
        off.step({});
        if (stopped < 0 && abs(on.angular_velocity(1).y) < fx("0.001")) stopped = f + 1;
        if (f == 59) {
            // One second in: 1.96 rad/s lost, within a few percent.
            EXPECT_GT(on.angular_velocity(1).y, fx("2.9"));
            EXPECT_LT(on.angular_velocity(1).y, fx("3.2"));
        }
    }
    ASSERT_GT(stopped, 0) << "the spin never stopped";
    EXPECT_GT(stopped, 140);
    EXPECT_LT(stopped, 170);
    EXPECT_LT(abs(on.angular_velocity(1).y), fx("0.001")) << "and stays stopped";
    EXPECT_GT(off.angular_velocity(1).y, fx("4.99")) << "no torque about the normal without it";
}

// A ball rolling at 2 m/s without slipping (w = -v / r about z).
World rolling_ball(const char* roll) {
    SceneDesc s = floor_scene("0", roll);
    BodyDesc b = ball(v3("0", "0.5", "0"));
    b.velocity = v3("2", "0", "0");
    b.angular_velocity = v3("0", "0", "-4");
    s.bodies.push_back(b);
    return World(s);
}

TEST(AngularFriction, RollingBallSlowsWithRollingResistance) {
    World on = rolling_ball("0.01"), off = rolling_ball("0");
    for (int f = 0; f < 120; ++f) {
        on.step({});
        off.step({});
    }
    // Resistance 0.01 m: deceleration (0.01 g / r) / (1 + I / (m r^2)) = 0.14 m/s^2, 0.28 m/s in 2 s.
    EXPECT_GT(off.velocity(1).x, fx("1.99")) << "nothing slows a rolling ball without it";
    EXPECT_LT(on.velocity(1).x, fx("1.76"));
    EXPECT_GT(on.velocity(1).x, fx("1.68"));
    // Still rolling, not sliding: w = -v / r.
    EXPECT_LT(abs(on.angular_velocity(1).z * fx("0.5") + on.velocity(1).x), fx("0.01"));
}

// 30 balls dropped in a 3 x 3 m pen, in layers, with warm starting (without it the four
// iterations' residual keeps a pile's upper balls turning at ~0.05 rad/s, at the sleep
// threshold, whatever the coefficients): they settle into a pile whose balls keep spinning
// about their contact normals without spinning friction (no sleep), and come to rest and fall
// asleep whole with it.
SceneDesc pile(const char* spin) {
    SceneDesc s = floor_scene(spin, "0");
    s.rigid.sleeping.enabled = true;
    s.rigid.warm_starting = true;
    const auto wall = [&](const char* x, const char* z, const char* hx, const char* hz) {
        BodyDesc w;
        w.shape = Shape::Box;
        w.position = v3(x, "2", z);
        w.half_extents = v3(hx, "2", hz);
        s.bodies.push_back(w);
    };
    wall("-2", "0", "0.5", "2");
    wall("2", "0", "0.5", "2");
    wall("0", "-2", "2", "0.5");
    wall("0", "2", "2", "0.5");
    for (int i = 0; i < 30; ++i) {
        const int layer = i / 9, k = i % 9;
        const std::int64_t x = (k % 3 - 1) * Fixed::kOne + (layer % 2) * (Fixed::kOne / 4) + (k * Fixed::kOne / 37);
        const std::int64_t z = (k / 3 - 1) * Fixed::kOne - (layer % 2) * (Fixed::kOne / 5) + (i * Fixed::kOne / 53);
        BodyDesc b = ball({Fixed::from_raw(x), Fixed::from_raw(Fixed::kOne + layer * Fixed::kOne * 11 / 10), Fixed::from_raw(z)});
        b.radius = fx("0.4");
        s.bodies.push_back(b);
    }
    return s;
}

std::size_t asleep_count(const World& w) {
    std::size_t n = 0;
    for (BodyId id : w.dynamic_ids()) n += w.asleep(id);
    return n;
}

TEST(AngularFriction, SmallPileFallsAsleepWholeWithSpinningFriction) {
    World on(pile("0.02")), off(pile("0"));
    int all_asleep = -1;
    for (int f = 0; f < 900 && all_asleep < 0; ++f) {
        on.step({});
        if (asleep_count(on) == 30) all_asleep = f + 1;
    }
    for (int f = 0; f < 900; ++f) off.step({});
    EXPECT_GT(all_asleep, 0) << "the pile never fell asleep whole; asleep: " << asleep_count(on);
    EXPECT_LT(all_asleep, 600);
    EXPECT_EQ(asleep_count(off), 0u) << "without spinning friction the balls keep spinning";
}

// The angular rows run in each island's (or colour range's) sweep: the bits must be the same at
// 1, 2 and 3 workers and with a runner that runs tasks backwards, plain and graph-coloured with
// warm starting; and the rows must change the motion.
TEST(AngularFriction, SameBitsAtAnyWorkerCount) {
    for (const bool coloured : {false, true}) {
        SceneDesc s = floor_scene("0.03", "0.01");
        s.rigid.sleeping.enabled = true;
        s.rigid.graph_colouring = s.rigid.warm_starting = coloured;
        for (int row = 0; row < 12; ++row)
            for (int i = 0; i < 25; ++i) {
                BodyDesc b = ball({Fixed::from_raw((i - 12) * (Fixed::kOne * 101 / 100)), Fixed::from_raw(Fixed::kOne / 2 + (i % 2) * Fixed::kOne),
                                   Fixed::from_raw(row * (Fixed::kOne * 3 / 2))});
                b.angular_velocity = {Fixed::from_raw((i % 5) * Fixed::kOne / 3), Fixed::from_int(row % 4), Fixed::zero()};
                if ((row + i) % 3 == 0) {
                    b.shape = Shape::Box;
                    b.half_extents = v3("0.5", "0.5", "0.5");
                }
                s.bodies.push_back(b);
            }
        for (int k = 0; k < 5; ++k) {
            BodyDesc b = ball({Fixed::from_int(4 * k - 8), Fixed::from_raw(Fixed::kOne / 2), Fixed::from_int(-6)});
            b.velocity = v3("0", "0", "4");
            s.bodies.push_back(b);
        }
        SceneDesc plain = s;
        plain.rigid.spinning_friction = plain.rigid.rolling_friction = Fixed::zero();
        World one(s), two(s), three(s), backwards(s), without(plain);
        two.set_workers(2);
        three.set_workers(3);
        backwards.set_task_runner(4, [](std::size_t count, const std::function<void(std::size_t)>& task) {
            for (std::size_t i = count; i-- > 0;) task(i);
        });
        bool differs = false;
        for (int n = 0; n < 120; ++n) {
            for (World* w : {&one, &two, &three, &backwards, &without}) w->step({});
            const char* what = coloured ? "coloured" : "plain";
            ASSERT_EQ(checksum(two), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(three), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(backwards), checksum(one)) << what << " frame " << n + 1;
            differs = differs || checksum(without) != checksum(one);
        }
        EXPECT_TRUE(differs) << "the angular rows must change the motion";
    }
}

// The angular rows are scratch, not state: a world loaded from a snapshot taken mid-settle
// (balls still spinning against the rows) continues bit for bit, and the snapshot is as long
// as one of the same scene without them (the layout does not change).
TEST(AngularFriction, SnapshotReplaysWithoutNewState) {
    SceneDesc s = pile("0.02");
    s.rigid.rolling_friction = fx("0.005");
    World a(s);
    for (int f = 0; f < 100; ++f) a.step({});
    std::vector<std::uint8_t> snap(snapshot_size(a));
    save(a, snap);
    World plain(pile("0"));
    for (int f = 0; f < 100; ++f) plain.step({});
    std::vector<std::uint8_t> plain_snap(snapshot_size(plain));
    save(plain, plain_snap);
    EXPECT_EQ(snapshot_body_bytes(snap), snapshot_body_bytes(plain_snap));
    EXPECT_EQ(snap[12], plain_snap[12]) << "the layout word";
    World b(s);
    ASSERT_EQ(load(b, snap), "");
    bool turning = false;
    for (int n = 0; n < 200; ++n) {
        a.step({});
        b.step({});
        ASSERT_EQ(checksum(a), checksum(b)) << "frame " << n;
        if (n == 0)
            for (BodyId id : a.dynamic_ids()) turning = turning || length_sq_wide(a.angular_velocity(id)) > mul_wide_unsigned(Fixed::kOne / 5, Fixed::kOne / 5);
    }
    EXPECT_TRUE(turning) << "the snapshot must catch balls still turning (over 0.2 rad/s)";
}

TEST(AngularFriction, ValidateNamesTheField) {
    SceneDesc s = floor_scene("0", "0");
    s.rigid.spinning_friction = fx("-0.01");
    EXPECT_EQ(validate(s), "rigid.spinning_friction must be within [0, 1] (metres)");
    s.rigid.spinning_friction = fx("0.02");
    s.rigid.rolling_friction = fx("1.5");
    EXPECT_EQ(validate(s), "rigid.rolling_friction must be within [0, 1] (metres)");
    s.rigid.rolling_friction = fx("0.01");
    EXPECT_EQ(validate(s), "");
}

}  // namespace
}  // namespace lockroll::sim
