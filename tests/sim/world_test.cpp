// Physics laws of the World: free fall against the integrator's analytic solution, momentum
// through collisions, restitution, the controller rule, and that nothing leaves a closed room.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "sim/snapshot.h"
#include "sim/world.h"
#include "tests/sim/scene_parts.h"

namespace lockroll::sim {
namespace {

using test::d;
using test::fx;
using test::v3;

BodyDesc sphere(Vec3 pos, Vec3 vel, const char* radius, const char* mass) {
    BodyDesc b = test::ball(pos, radius, mass);
    b.velocity = vel;
    return b;
}

// A static box whose top face is y = 0, `half` wide each way and 2 m deep.
BodyDesc floor_box(const char* half) { return test::floor_box(half, "1"); }

TEST(World, FreeFallMatchesSemiImplicitEulerClosedForm) {
    SceneDesc s;
    s.bodies.push_back(sphere(v3("0", "100", "0"), v3("1.5", "2", "0"), "0.5", "1"));
    World w(s);
    const double g = -9.81, dt = 1.0 / 60.0, y0 = 100, vy0 = 2, vx0 = 1.5;
    for (int n = 1; n <= 120; ++n) {  // 2 s
        w.step({});
        // Semi-implicit Euler: v_n = v0 + n g dt; x_n = x0 + n v0 dt + g dt^2 n(n+1)/2.
        const double vy = vy0 + n * g * dt;
        const double y = y0 + n * vy0 * dt + g * dt * dt * n * (n + 1) / 2.0;
        ASSERT_NEAR(d(w.velocity(0).y), vy, 1e-6) << "frame " << n;
        ASSERT_NEAR(d(w.position(0).y), y, 1e-6) << "frame " << n;
        ASSERT_NEAR(d(w.position(0).x), n * vx0 * dt, 1e-6) << "frame " << n;
    }
    // The continuous solution differs by the integrator's O(dt) error: g dt t / 2 ~ 0.16 m at 2 s.
    const double t = 2.0, continuous = y0 + vy0 * t + g * t * t / 2;
    EXPECT_NEAR(d(w.position(0).y), continuous, 0.2);
    EXPECT_EQ(w.overflow_count(), 0u);
}

TEST(World, HeadOnElasticSpheresSwapVelocitiesAndConserveMomentum) {
    SceneDesc s;
    s.gravity = {};
    s.bodies.push_back(sphere(v3("-1", "0", "0"), v3("5", "0", "0"), "0.5", "1"));
    s.bodies.push_back(sphere(v3("1", "0", "0"), v3("-10", "0", "0"), "0.5", "1"));
    World w(s);
    const std::int64_t p0 = w.velocity(0).x.raw + w.velocity(1).x.raw;
    for (int n = 0; n < 30; ++n) w.step({});
    // Equal masses, e = 1 (sphere-sphere rule): they exchange velocities.
    EXPECT_NEAR(d(w.velocity(0).x), -10.0, 1e-5);
    EXPECT_NEAR(d(w.velocity(1).x), 5.0, 1e-5);
    // Equal masses: the impulse is applied with identical rounding to both, so momentum is exact.
    EXPECT_EQ(w.velocity(0).x.raw + w.velocity(1).x.raw, p0);
    EXPECT_EQ(w.velocity(0).y.raw, 0);
    EXPECT_EQ(w.velocity(1).z.raw, 0);
}

TEST(World, MomentumConservedWithUnequalMasses) {
    SceneDesc s;
    s.gravity = {};
    s.bodies.push_back(sphere(v3("-1", "0.1", "0"), v3("3", "0", "0"), "0.5", "2"));
    s.bodies.push_back(sphere(v3("1", "-0.1", "0.05"), v3("-1", "0", "0"), "0.5", "5"));
    World w(s);
    auto momentum = [&](auto axis) {
        return axis(w.velocity(0)) * 2.0 + axis(w.velocity(1)) * 5.0;
    };
    auto mx = [](const Vec3& v) { return d(v.x); };
    auto my = [](const Vec3& v) { return d(v.y); };
    const double px = momentum(mx), py = momentum(my);
    for (int n = 0; n < 60; ++n) w.step({});
    ASSERT_NE(d(w.velocity(0).y), 0.0) << "the collision must have happened off-axis";
    // Each impulse is rounded separately per body: a few ulps per contact.
    EXPECT_NEAR(momentum(mx), px, 1e-7);
    EXPECT_NEAR(momentum(my), py, 1e-7);
}

TEST(World, SphereOnStaticBoxBouncesWithRestitutionPointEight) {
    SceneDesc s;
    s.gravity = {};
    s.bodies.push_back(floor_box("10"));
    s.bodies.push_back(sphere(v3("0", "0.6", "0"), v3("0", "-6", "0"), "0.5", "1"));
    World w(s);
    for (int n = 0; n < 10; ++n) w.step({});
    EXPECT_NEAR(d(w.velocity(1).y), 4.8, 1e-6);  // box-sphere rule e = 0.8
    EXPECT_EQ(w.position(0), floor_box("10").position) << "static bodies never move";
}

TEST(World, PerBodyRestitutionOverridesTable) {
    SceneDesc s;
    s.gravity = {};
    s.bodies.push_back(floor_box("10"));
    BodyDesc ball = sphere(v3("0", "0.6", "0"), v3("0", "-6", "0"), "0.5", "1");
    ball.restitution = Fixed::zero();
    s.bodies.push_back(ball);
    World w(s);
    for (int n = 0; n < 10; ++n) w.step({});
    EXPECT_EQ(w.velocity(1).y.raw, 0);  // e = 0: the approach velocity is removed exactly
}

TEST(World, CapsuleStandsOnFloorAndSpheresBounceOffIt) {
    SceneDesc s;
    s.bodies.push_back(floor_box("10"));
    BodyDesc cap;
    cap.shape = Shape::Capsule;
    cap.position = v3("0", "1.2", "0");
    cap.radius = fx("0.4");
    cap.half_height = fx("0.5");
    cap.mass = fx("5");
    s.bodies.push_back(cap);
    s.bodies.push_back(sphere(v3("-2", "1.2", "0"), v3("4", "0", "0"), "0.2", "1"));
    s.gravity = {};
    World w(s);
    for (int n = 0; n < 60; ++n) w.step({});
    EXPECT_LT(d(w.velocity(2).x), 0.0) << "the sphere bounced off the capsule's side";
    EXPECT_GT(d(w.velocity(1).x), 0.0) << "and pushed it";
}

TEST(World, BoxesStackWithoutSinking) {
    SceneDesc s;
    s.bodies.push_back(floor_box("10"));
    for (int k = 0; k < 3; ++k) {
        BodyDesc b;
        b.shape = Shape::Box;
        b.half_extents = v3("0.5", "0.5", "0.5");
        b.position = {Fixed::zero(), Fixed::from_raw(Fixed::kOne / 2 + k * Fixed::kOne), Fixed::zero()};
        b.mass = Fixed::one();
        s.bodies.push_back(b);
    }
    World w(s);
    for (int n = 0; n < 300; ++n) w.step({});
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(d(w.position(static_cast<BodyId>(1 + k)).y), 0.5 + k, 0.02);
}

TEST(World, ControllerReachesTargetSpeedAtTheDocumentedRate) {
    SceneDesc s;
    s.gravity = {};
    BodyDesc p = sphere(v3("0", "0", "0"), v3("0", "0", "0"), "0.5", "1");
    p.player = 0;
    s.bodies.push_back(p);
    World w(s);
    const PlayerInput full{127, -127, 0};
    const PlayerInput in[1] = {full};
    w.step(in);
    // acceleration 40 m/s^2 * dt per frame toward the 6 m/s target; dt is 1/60 rounded to Q32.32.
    EXPECT_EQ(w.velocity(0).z, Fixed::from_int(40) * w.dt());
    EXPECT_EQ(w.velocity(0).x, -(Fixed::from_int(40) * w.dt()));
    EXPECT_NEAR(d(w.velocity(0).z), 40.0 / 60.0, 1e-8);
    for (int n = 0; n < 20; ++n) w.step(in);
    EXPECT_NEAR(d(w.velocity(0).z), 6.0, 1e-8);
    EXPECT_NEAR(d(w.velocity(0).x), -6.0, 1e-8);
    // -128 is clamped to -127: same result as -127.
    World w2(s);
    const PlayerInput m128[1] = {PlayerInput{-128, 0, 0}};
    const PlayerInput m127[1] = {PlayerInput{-127, 0, 0}};
    World w3(s);
    w2.step(m128);
    w3.step(m127);
    EXPECT_EQ(w2.velocity(0), w3.velocity(0));
}

TEST(World, NothingLeavesAClosedRoom) {
    SceneDesc s;
    add_room(s, v3("-3", "0", "-3"), v3("3", "3", "3"), Fixed::one());
    SpawnerDesc sp;
    sp.count = 40;
    sp.radius = fx("0.2");
    sp.region_min = v3("-3", "0", "-3");
    sp.region_max = v3("3", "3", "3");
    sp.max_speed = fx("8");
    sp.seed = 3;
    expand_spawner(s, sp);
    World w(s);
    for (int n = 0; n < 600; ++n) {
        w.step({});
        for (BodyId id : w.dynamic_ids()) {
            const Vec3& p = w.position(id);
            ASSERT_TRUE(abs(p.x) <= fx("3") && abs(p.z) <= fx("3") && p.y.raw >= 0 && p.y <= fx("3"))
                << "body " << id << " escaped at frame " << n;
        }
    }
    EXPECT_EQ(w.overflow_count(), 0u);
}

TEST(World, SaturationIsCountedInState) {
    SceneDesc s;
    s.gravity = {};
    s.bodies.push_back(sphere(v3("2147483000", "0", "0"), v3("2147483000", "0", "0"), "1", "1"));
    World w(s);
    const std::uint64_t before = checksum(w);
    w.step({});
    EXPECT_EQ(w.position(0).x, Fixed::max());
    EXPECT_GT(w.overflow_count(), 0u);
    EXPECT_NE(checksum(w), before);
}

TEST(World, RejectsInvalidScenes) {
    SceneDesc s;
    s.bodies.push_back(sphere(v3("0", "0", "0"), v3("0", "0", "0"), "0", "1"));
    EXPECT_THROW(World{s}, std::invalid_argument);
    s.bodies[0].radius = Fixed::one();
    s.bodies[0].player = 1;  // slot 0 missing
    EXPECT_THROW(World{s}, std::invalid_argument);
}

TEST(World, BroadphasesAgreeBitForBit) {
    // Grid and sweep-and-prune emit pairs in different (each canonical) orders, so only scenes
    // whose contacts are isolated pairs must come out bit-identical: 20 pairs, each closing on
    // its own, never touching a neighbour.
    SceneDesc s;
    s.gravity = {};
    for (int k = 0; k < 20; ++k) {
        const Fixed x = Fixed::from_int(k * 4);
        s.bodies.push_back(sphere({x, Fixed::zero(), Fixed::zero()}, v3("1", "0", "0"), "0.5", "1"));
        s.bodies.push_back(sphere({x + Fixed::from_int(2), fx("0.3"), Fixed::zero()}, v3("-1", "0", "0"), "0.5", "1"));
    }
    SceneDesc a = s, b = s;
    a.broadphase = BroadphaseKind::SweepAndPrune;
    b.broadphase = BroadphaseKind::Grid;
    World wa(a), wb(b);
    for (int n = 0; n < 120; ++n) {
        wa.step({});
        wb.step({});
    }
    EXPECT_EQ(checksum(wa), checksum(wb));
    EXPECT_NE(wa.velocity(0).y.raw, 0) << "pairs must actually have collided";
}


// A pile for the parallel step: spheres and (rigid) boxes dropped in a grid onto a floor,
// close enough to touch, so there are many islands and some large ones.
SceneDesc pile(bool rigid) {
    SceneDesc s;
    s.rigid.enabled = rigid;
    s.bodies.push_back(floor_box("40"));
    for (int i = 0; i < 1200; ++i) {
        const int x = i % 20, z = (i / 20) % 20, y = i / 400;
        BodyDesc b = sphere({Fixed::from_raw((x - 10) * (Fixed::kOne * 9 / 10)), Fixed::from_raw(Fixed::kOne / 2 + y * Fixed::kOne),
                             Fixed::from_raw((z - 10) * (Fixed::kOne * 9 / 10) + (x % 3) * (Fixed::kOne / 7))},
                            v3("0", "0", "0"), "0.5", "1");
        if (i % 4 == 1) {
            b.shape = Shape::Box;
            b.half_extents = v3("0.4", "0.4", "0.4");
        }
        s.bodies.push_back(b);
    }
    return s;
}

TEST(World, ParallelStepGivesTheSequentialBits) {
    for (const bool rigid : {false, true}) {
        World seq(pile(rigid)), pool(pile(rigid)), backwards(pile(rigid));
        pool.set_workers(3);
        backwards.set_task_runner(5, [](std::size_t count, const std::function<void(std::size_t)>& task) {
            for (std::size_t i = count; i-- > 0;) task(i);
        });
        EXPECT_EQ(seq.workers(), 1);
        EXPECT_EQ(pool.workers(), 3);
        EXPECT_EQ(backwards.workers(), 5);
        for (int n = 0; n < 40; ++n) {
            seq.step({});
            pool.step({});
            backwards.step({});
            ASSERT_EQ(checksum(pool), checksum(seq)) << (rigid ? "rigid" : "particles") << " frame " << n + 1;
            ASSERT_EQ(checksum(backwards), checksum(seq)) << (rigid ? "rigid" : "particles") << " frame " << n + 1;
        }
        EXPECT_NE(seq.position(1200).y, pile(rigid).bodies[1200].position.y) << "the pile must have moved";
        // A copy steps sequentially (threads are not state) and stays in step.
        World copy(pool);
        EXPECT_EQ(copy.workers(), 1);
        copy.step({});
        pool.step({});
        EXPECT_EQ(checksum(copy), checksum(pool));
    }
}

// rigid.graph_colouring: the passes go colour by colour, each colour cut over the workers, so
// the bits must be the same at 1, 2 and 3 workers and with a runner that runs tasks backwards,
// with the plain rows and with every opt-in pass that is Gauss-Seidel over the manifolds (warm
// start, block rows, split impulses); and the flag must change the order (other bits).
TEST(World, ColouredRigidStepSameBitsAtAnyWorkerCount) {
    for (const bool stack_options : {false, true}) {
        SceneDesc s = pile(true);
        s.rigid.graph_colouring = true;
        if (stack_options) s.rigid.warm_starting = s.rigid.block_solver = s.rigid.split_impulse = s.rigid.reduce_manifold = true;
        SceneDesc plain = s;
        plain.rigid.graph_colouring = false;
        World one(s), two(s), three(s), backwards(s), uncoloured(plain);
        two.set_workers(2);
        three.set_workers(3);
        backwards.set_task_runner(4, [](std::size_t count, const std::function<void(std::size_t)>& task) {
            for (std::size_t i = count; i-- > 0;) task(i);
        });
        bool differs = false;
        for (int n = 0; n < 40; ++n) {
            for (World* w : {&one, &two, &three, &backwards, &uncoloured}) w->step({});
            const char* what = stack_options ? "stack options" : "plain";
            ASSERT_EQ(checksum(two), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(three), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(backwards), checksum(one)) << what << " frame " << n + 1;
            differs = differs || checksum(uncoloured) != checksum(one);
        }
        EXPECT_TRUE(differs) << "the colouring must change the row order";
        EXPECT_NE(one.position(1200).y, s.bodies[1200].position.y) << "the pile must have moved";
    }
}

// rigid.sleeping: the sleep bookkeeping is sequential, but the per-body phases run over the
// awake set cut over the workers and the pairs it filters come from the parallel broadphase, so
// the bits (sleep words included) must be the same at 1, 2 and 3 workers and with a runner that
// runs tasks backwards, plain and graph-coloured with warm starting. Rows of resting bodies
// (1 cm apart within a row, 0.5 m between rows) fall asleep; balls rolled at the first row wake
// rows as they go.
TEST(World, SleepingSameBitsAtAnyWorkerCount) {
    for (const bool coloured : {false, true}) {
        SceneDesc s;
        s.rigid.enabled = true;
        s.rigid.sleeping.enabled = true;
        s.rigid.graph_colouring = s.rigid.warm_starting = coloured;
        s.bodies.push_back(floor_box("40"));
        for (int row = 0; row < 24; ++row)
            for (int i = 0; i < 25; ++i) {
                BodyDesc b = sphere({Fixed::from_raw((i - 12) * (Fixed::kOne * 101 / 100)), Fixed::from_raw(Fixed::kOne / 2),
                                     Fixed::from_raw(row * (Fixed::kOne * 3 / 2))},
                                    v3("0", "0", "0"), "0.5", "1");
                if ((row + i) % 3 == 0) {
                    b.shape = Shape::Box;
                    b.half_extents = v3("0.5", "0.5", "0.5");
                }
                s.bodies.push_back(b);
            }
        for (int k = 0; k < 5; ++k)
            s.bodies.push_back(sphere({Fixed::from_int(4 * k - 8), Fixed::from_raw(Fixed::kOne / 2), Fixed::from_int(-6)},
                                      v3("0", "0", "4"), "0.5", "1"));
        World one(s), two(s), three(s), backwards(s);
        two.set_workers(2);
        three.set_workers(3);
        backwards.set_task_runner(4, [](std::size_t count, const std::function<void(std::size_t)>& task) {
            for (std::size_t i = count; i-- > 0;) task(i);
        });
        std::size_t most_asleep = 0, woken = 0;
        std::vector<std::uint8_t> was(s.bodies.size(), 0);
        for (int n = 0; n < 150; ++n) {
            for (World* w : {&one, &two, &three, &backwards}) w->step({});
            const char* what = coloured ? "coloured" : "plain";
            ASSERT_EQ(checksum(two), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(three), checksum(one)) << what << " frame " << n + 1;
            ASSERT_EQ(checksum(backwards), checksum(one)) << what << " frame " << n + 1;
            std::size_t asleep = 0;
            for (BodyId id : one.dynamic_ids()) {
                asleep += one.asleep(id);
                woken += was[id] && !one.asleep(id);
                was[id] = one.asleep(id);
            }
            most_asleep = std::max(most_asleep, asleep);
        }
        EXPECT_GT(most_asleep, 500u) << "the rows must fall asleep";
        EXPECT_GT(woken, 20u) << "the rolling balls must wake some";
    }
}

TEST(World, ParallelSaturationIsCountedOnce) {
    // 2000 bodies that each saturate on their first step: the per-body phases run them on
    // several threads, and the count must be the sequential one.
    SceneDesc s;
    s.gravity = {};
    for (int i = 0; i < 2000; ++i)
        s.bodies.push_back(sphere({Fixed::from_int(2147483000 - 0), Fixed::from_int(3 * i), Fixed::zero()},
                                  v3("2147483000", "0", "0"), "1", "1"));
    World seq(s), par(s);
    par.set_task_runner(4, [](std::size_t count, const std::function<void(std::size_t)>& task) {
        std::vector<std::thread> threads;
        for (std::size_t i = 0; i < count; ++i) threads.emplace_back([&task, i] { task(i); });
        for (std::thread& t : threads) t.join();
    });
    seq.step({});
    par.step({});
    EXPECT_GE(seq.overflow_count(), 2000u);
    EXPECT_EQ(par.overflow_count(), seq.overflow_count());
    EXPECT_EQ(checksum(par), checksum(seq));
}

TEST(World, ParallelSettingsRejectBadCountsClearly) {
    World w(pile(false));
    for (int bad : {0, -1}) {
        try {
            w.set_workers(bad);
            FAIL() << "set_workers(" << bad << ") accepted";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("workers must be at least 1 (got " + std::to_string(bad) + ")"),
                      std::string::npos)
                << e.what();
        }
    }
    EXPECT_THROW(w.set_task_runner(0, [](std::size_t, const std::function<void(std::size_t)>&) {}),
                 std::invalid_argument);
    EXPECT_THROW(w.set_task_runner(2, TaskRunner{}), std::invalid_argument);
    EXPECT_EQ(w.workers(), 1) << "a rejected setting leaves the world as it was";
    // A runner that drops tasks breaks the contract: the step says so instead of going on.
    w.set_task_runner(2, [](std::size_t, const std::function<void(std::size_t)>&) {});
    EXPECT_THROW(w.step({}), std::logic_error);
    w.set_workers(1);
    EXPECT_EQ(w.workers(), 1);
}


// The default step reads each body's sizes, mass, restitution and gravity through a class
// shared by bodies that agree on all of them (StepKernel::BodyClass), and each pair's mass and
// restitution terms from a table by class pair (up to 16 classes) or from a list by pair
// (beyond). Bodies of many kinds in one scene, in groups far apart (12 m) on one floor, must
// move bit for bit as each group does alone (where the class can only be its own), with 8
// classes and with 32, sequentially and at 2 workers: a body reading another kind's class, or
// a pair another pair's terms, would not.
TEST(World, BodiesOfManyKindsMoveAsEachKindAlone) {
    std::vector<std::vector<BodyDesc>> groups;
    auto at = [](int slot, const char* y) { return Vec3{Fixed::from_int(12 * slot - 100), fx(y), Fixed::zero()}; };
    groups.push_back({sphere(at(0, "2"), v3("0.5", "0", "0"), "0.3", "1")});
    groups.push_back({sphere(at(1, "2"), v3("0", "1", "0"), "0.5", "1")});
    groups.push_back({sphere(at(2, "3"), v3("0", "0", "0"), "0.3", "2")});
    groups.back()[0].restitution = fx("0.8");
    groups.push_back({sphere(at(3, "2"), v3("0", "0", "0.5"), "0.3", "1")});
    groups.back()[0].gravity_scale = fx("0.5");
    BodyDesc cap = sphere(at(4, "2"), v3("0", "0", "0"), "0.2", "3");
    cap.shape = Shape::Capsule;
    cap.half_height = fx("0.4");
    groups.push_back({cap});
    // Light and heavy balls meeting head on above the floor (the pairs' mass terms); from the
    // sixth group on, each pair of another size and mass ratio (two more classes each).
    for (int k = 0; k < 13; ++k) {
        const Vec3 left = at(5 + k, "1");
        BodyDesc light = sphere(left, v3("2", "0", "0"), "0.25", "1");
        BodyDesc heavy = sphere(Vec3{left.x + fx("1.5"), fx("1"), Fixed::zero()}, v3("-1", "0", "0"), "0.4", "5");
        light.radius = light.radius + Fixed::from_int(k) / Fixed::from_int(100);
        heavy.mass = heavy.mass + Fixed::from_int(k);
        groups.push_back({light, heavy});
    }
    const int frames = 150;

    for (const std::size_t used : {std::size_t{6}, groups.size()}) {  // 8 classes (floor included), 32
        SceneDesc mixed;
        mixed.bodies.push_back(floor_box("120"));
        for (std::size_t k = 0; k < used; ++k) mixed.bodies.insert(mixed.bodies.end(), groups[k].begin(), groups[k].end());
        World all(mixed), all2(mixed);
        all2.set_workers(2);
        for (int f = 0; f < frames; ++f) {
            all.step({});
            all2.step({});
        }
        BodyId id = 1;
        for (std::size_t k = 0; k < used; ++k) {
            SceneDesc alone;
            alone.bodies.push_back(floor_box("120"));
            alone.bodies.insert(alone.bodies.end(), groups[k].begin(), groups[k].end());
            World w(alone);
            for (int f = 0; f < frames; ++f) w.step({});
            for (BodyId j = 1; j <= groups[k].size(); ++j, ++id) {
                EXPECT_EQ(all.position(id), w.position(j)) << used << " groups: group " << k << ", body " << j;
                EXPECT_EQ(all.velocity(id), w.velocity(j)) << used << " groups: group " << k << ", body " << j;
                EXPECT_EQ(all2.position(id), w.position(j)) << used << " groups, 2 workers: group " << k << ", body " << j;
                EXPECT_EQ(all2.velocity(id), w.velocity(j)) << used << " groups, 2 workers: group " << k << ", body " << j;
            }
            // Each group has come to the floor (so sizes and contacts were exercised).
            EXPECT_LT(d(w.position(1).y), 1.5) << "group " << k;
        }
    }
}

}  // namespace
}  // namespace lockroll::sim
