// rigid.sleeping (sim/rigid_solver_sleeping.cpp; docs/physics.md "Sleeping"): a resting body
// falls asleep and stays bit-still, a sleeping pile wakes whole, players never sleep, and the
// sleep state is state (snapshots replay it bit for bit; loads reject impossible words).
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "sim/rigid_solver.h"
#include "sim/snapshot.h"
#include "sim/world.h"
#include "tests/sim/scene_parts.h"

namespace lockroll::sim {
namespace {

using test::fx;
using test::v3;

// A rigid scene with sleeping on (default thresholds: 0.05 m/s, 0.05 rad/s, 0.5 s = 30 frames
// at 60 Hz), no bounce, and a static floor whose top face is y = 0.
SceneDesc sleepy_floor() {
    SceneDesc s = test::rigid_floor("50");
    s.rigid.sleeping.enabled = true;
    test::no_bounce(s);
    return s;
}

BodyDesc ball(const char* x, const char* y) { return test::ball(v3(x, y, "0")); }
BodyDesc box(const char* x, const char* y) { return test::box(v3(x, y, "0"), v3("0.5", "0.5", "0.5")); }

bool still(const World& w, BodyId id, const SceneDesc& s) {
    const auto sq = [](const Vec3& v) { return length_sq_wide(v); };
    const auto thr = [](Fixed f) { return mul_wide_unsigned(static_cast<std::uint64_t>(f.raw), static_cast<std::uint64_t>(f.raw)); };
    return sq(w.velocity(id)) < thr(s.rigid.sleeping.linear_speed) && sq(w.angular_velocity(id)) < thr(s.rigid.sleeping.angular_speed);
}

TEST(Sleeping, DroppedBallFallsAsleepSoonAfterItStopsThenStaysBitStill) {
    SceneDesc s = sleepy_floor();
    s.bodies.push_back(ball("0", "2"));
    World w(s);
    EXPECT_EQ(w.rigid_solver().sleep_frames(), 30u);  // ceil(0.5 s * 60 Hz)
    int last_moving = -1, slept = -1;
    for (int f = 0; f < 600 && slept < 0; ++f) {
        w.step({});
        if (w.asleep(1))
            slept = f;
        else if (!still(w, 1, s))
            last_moving = f;
    }
    ASSERT_GE(slept, 0) << "the ball never fell asleep";
    EXPECT_GT(last_moving, 10) << "it fell first";
    // Asleep once it has been still for the time to sleep (its island is itself: the floor is static).
    EXPECT_LE(slept - last_moving, 30);
    EXPECT_EQ(w.velocity(1), Vec3{});
    EXPECT_EQ(w.angular_velocity(1), Vec3{});
    const Vec3 p = w.position(1);
    const Quat q = w.orientation(1);
    EXPECT_LT(p.y, fx("0.51"));
    for (int f = 0; f < 300; ++f) {
        w.step({});
        ASSERT_TRUE(w.asleep(1)) << "frame " << f;
        ASSERT_EQ(w.position(1), p) << "frame " << f;
        ASSERT_EQ(w.orientation(1), q) << "frame " << f;
    }
    // Without sleeping the same ball is stepped for ever (and never reports asleep).
    s.rigid.sleeping.enabled = false;
    World awake(s);
    for (int f = 0; f < 200; ++f) awake.step({});
    EXPECT_FALSE(awake.asleep(1));
    EXPECT_TRUE(awake.sleep_state().empty());
}

// Three boxes side by side on the floor, 1 cm apart (candidate pairs, no touching), fall asleep
// together; a ball rolled at the first one wakes the row whole, the far box included, though the
// ball never comes near it.
TEST(Sleeping, SleepingRowWakesWholeWhenAMovingBodyReachesIt) {
    SceneDesc s = sleepy_floor();
    s.bodies.push_back(box("0", "0.5"));
    s.bodies.push_back(box("1.01", "0.5"));
    s.bodies.push_back(box("2.02", "0.5"));
    s.bodies.push_back(ball("-8", "0.5"));
    World w(s);
    int all_asleep = -1;
    for (int f = 0; f < 240 && all_asleep < 0; ++f) {
        w.step({});
        if (w.asleep(1) && w.asleep(2) && w.asleep(3)) all_asleep = f;
    }
    ASSERT_GE(all_asleep, 0) << "the row never fell asleep";
    // A second world: the same row asleep (loaded), the ball (asleep or not: made awake with a
    // count of 0) rolling at it at 4 m/s along +x.
    std::vector<std::uint8_t> snap(snapshot_size(w));
    save(w, snap);
    const std::size_t ball_index = 3;  // dynamic order: 1, 2, 3, 4
    const std::size_t body = kSnapshotSleepBodyBytes;
    std::uint8_t* rec = snap.data() + kSnapshotHeaderBytes + body * ball_index;
    const std::int64_t vx = Fixed::from_int(4).raw;
    for (int i = 0; i < 8; ++i) rec[24 + i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(vx) >> (8 * i));
    for (int i = 0; i < 4; ++i) rec[kSnapshotRigidBodyBytes + i] = 0;
    World hit(s);
    ASSERT_EQ(load(hit, snap), "");
    ASSERT_TRUE(hit.asleep(1) && hit.asleep(2) && hit.asleep(3));
    ASSERT_FALSE(hit.asleep(4));
    const Vec3 far = hit.position(3);
    int woke = -1;
    for (int f = 0; f < 240 && woke < 0; ++f) {
        hit.step({});
        const bool a = hit.asleep(1), b = hit.asleep(2), c = hit.asleep(3);
        if (!a || !b || !c) {
            woke = f;
            EXPECT_FALSE(a);
            EXPECT_FALSE(b) << "the middle box wakes with the first";
            EXPECT_FALSE(c) << "the far box wakes with the first: the whole component";
            // The ball reached the first box only.
            EXPECT_LT(hit.position(4).x, fx("-0.9"));
        }
    }
    ASSERT_GE(woke, 0) << "the row never woke";
    // And the push travels along the row: the far box moves.
    for (int f = 0; f < 120; ++f) hit.step({});
    EXPECT_NE(hit.position(3).x, far.x);
}

TEST(Sleeping, PlayerBodyNeverSleeps) {
    SceneDesc s = sleepy_floor();
    BodyDesc p = ball("0", "0.5");
    p.player = 0;
    s.bodies.push_back(p);
    s.bodies.push_back(ball("5", "0.5"));
    World w(s);
    for (int f = 0; f < 400; ++f) {
        w.step({});
        ASSERT_FALSE(w.asleep(1)) << "frame " << f;
        ASSERT_EQ(w.sleep_state()[1], 0u) << "a player's still count stays 0";
    }
    EXPECT_TRUE(w.asleep(2)) << "the other ball, resting as long, sleeps";
}

// A pile part asleep, part counting, saved and loaded, steps as the original bit for bit.
SceneDesc small_pile() {
    SceneDesc s = sleepy_floor();
    s.rigid.warm_starting = true;
    for (int i = 0; i < 40; ++i) {
        const int x = i % 5, z = (i / 5) % 4, y = i / 20;
        BodyDesc b;
        b.shape = i % 3 == 1 ? Shape::Box : Shape::Sphere;
        b.radius = fx("0.5");
        b.half_extents = v3("0.45", "0.45", "0.45");
        b.mass = fx("1");
        b.position = {Fixed::from_raw(x * Fixed::kOne * 3), Fixed::from_raw(Fixed::kOne / 2 + y * Fixed::kOne * 11 / 10),
                      Fixed::from_raw(z * Fixed::kOne * 3 + (x % 2) * (Fixed::kOne / 5))};
        s.bodies.push_back(b);
    }
    return s;
}

TEST(Sleeping, SaveLoadMidRunReplaysBitForBit) {
    const SceneDesc s = small_pile();
    World a(s);
    bool asleep = false, counting = false;
    int f = 0;
    for (; f < 600 && !(asleep && counting); ++f) {
        a.step({});
        asleep = counting = false;
        for (BodyId id : a.dynamic_ids()) {
            asleep = asleep || a.asleep(id);
            counting = counting || (a.sleep_state()[id] > 0 && a.sleep_state()[id] < a.rigid_solver().sleep_frames());
        }
    }
    ASSERT_TRUE(asleep && counting) << "no frame with bodies asleep and others part-way";
    std::vector<std::uint8_t> snap(snapshot_size(a));
    save(a, snap);
    EXPECT_EQ(snapshot_body_bytes(snap), kSnapshotSleepBodyBytes);
    EXPECT_EQ(body_field_count(a), kSleepFields);
    World b(s);
    ASSERT_EQ(load(b, snap), "");
    EXPECT_EQ(checksum(b), checksum(a));
    for (int n = 0; n < 300; ++n) {
        a.step({});
        b.step({});
        ASSERT_EQ(checksum(a), checksum(b)) << "frame " << n;
    }
    // The sleep word is state: changing it changes the checksum, and narrowing names it.
    std::vector<std::uint8_t> other = snap;
    other[kSnapshotHeaderBytes + kSnapshotRigidBodyBytes] ^= 1;
    int field = -2;
    EXPECT_EQ(first_difference(snap, other, &field), 0);
    ASSERT_EQ(field, 13);
    EXPECT_STREQ(kBodyFieldNames[field], "sleep");
}

TEST(Sleeping, LoadRejectsImpossibleSleepWords) {
    SceneDesc s = small_pile();
    s.bodies[1].player = 0;  // body 1: a player
    World w(s);
    for (int f = 0; f < 30; ++f) w.step({});
    std::vector<std::uint8_t> snap(snapshot_size(w));
    save(w, snap);
    const auto word_at = [&](std::vector<std::uint8_t>& b, std::size_t index) {
        return b.data() + kSnapshotHeaderBytes + kSnapshotSleepBodyBytes * index + kSnapshotRigidBodyBytes;
    };
    const auto put = [](std::uint8_t* p, std::uint32_t v) {
        for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
    };
    const std::uint64_t before = checksum(w);
    {
        auto bad = snap;
        put(word_at(bad, 2), 31);  // above the 30 frames to sleep
        EXPECT_NE(load(w, bad).find("sleep word 31 is neither asleep nor a still count"), std::string::npos);
    }
    {
        auto bad = snap;
        put(word_at(bad, 0), World::kAsleep);  // the player
        EXPECT_NE(load(w, bad).find("a player body never sleeps"), std::string::npos);
    }
    {
        auto bad = snap;
        put(word_at(bad, 2), World::kAsleep);
        bad[kSnapshotHeaderBytes + kSnapshotSleepBodyBytes * 2 + 24] ^= 1;  // velocity.x
        EXPECT_NE(load(w, bad).find("must have zero velocity"), std::string::npos);
    }
    EXPECT_EQ(checksum(w), before) << "a rejected load leaves the world as it was";
    // A snapshot of the same scene without sleeping has another layout.
    s.rigid.sleeping.enabled = false;
    World plain(s);
    std::vector<std::uint8_t> p(snapshot_size(plain));
    save(plain, p);
    EXPECT_NE(load(w, p).find("the world needs 258 (rigid, warm starting, sleeping)"), std::string::npos) << load(w, p);
}

}  // namespace
}  // namespace lockroll::sim
