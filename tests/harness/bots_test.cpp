#include "harness/match/bots.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "harness/match/scene_loader.h"
#include "sim/scene.h"
#include "sim/world.h"

namespace lockroll::harness {
namespace {

using sim::Fixed;
using sim::PlayerInput;
using sim::Vec3;

Fixed fx(std::int64_t num, std::int64_t den = 1) { return Fixed::ratio(num, den); }
Vec3 v3(Fixed x, Fixed y, Fixed z) { return {x, y, z}; }

// A 20 m room with one player box at the origin and the given balls (no initial velocity).
sim::SceneDesc room_with(const std::vector<Vec3>& balls, bool extra_player = false) {
    sim::SceneDesc scene;
    scene.name = "bots-test";
    sim::add_room(scene, v3(fx(-10), fx(0), fx(-10)), v3(fx(10), fx(6), fx(10)), fx(1));
    sim::BodyDesc player;
    player.shape = sim::Shape::Box;
    player.position = v3(fx(0), fx(9, 10), fx(0));
    player.half_extents = v3(fx(2, 5), fx(9, 10), fx(2, 5));
    player.mass = fx(5);
    player.player = 0;
    scene.bodies.push_back(player);
    if (extra_player) {  // a sphere-shaped player: never counts as a ball
        sim::BodyDesc p1;
        p1.shape = sim::Shape::Sphere;
        p1.position = v3(fx(1, 2), fx(1, 4), fx(0));
        p1.radius = fx(1, 4);
        p1.mass = fx(1);
        p1.player = 1;
        scene.bodies.push_back(p1);
    }
    for (const Vec3& at : balls) {
        sim::BodyDesc b;
        b.shape = sim::Shape::Sphere;
        b.position = at;
        b.radius = fx(1, 4);
        b.mass = fx(1);
        scene.bodies.push_back(b);
    }
    return scene;
}

Fixed distance(const sim::World& w, sim::BodyId a, sim::BodyId b) {
    return sim::length(w.position(a) - w.position(b));
}

TEST(BotKind, ParsesAndNames) {
    EXPECT_EQ(parse_bot_kind("random"), BotKind::Random);
    EXPECT_EQ(parse_bot_kind("chase"), BotKind::Chase);
    EXPECT_FALSE(parse_bot_kind("Chase").has_value());
    EXPECT_FALSE(parse_bot_kind("").has_value());
    EXPECT_STREQ(bot_kind_name(BotKind::Random), "random");
    EXPECT_STREQ(bot_kind_name(BotKind::Chase), "chase");
}

TEST(Bot, RejectsBadConfig) {
    EXPECT_THROW(Bot({.kind = BotKind::Random, .seed = 1, .tick_rate = 0}, 0), std::invalid_argument);
    EXPECT_THROW(Bot({.kind = BotKind::Random, .seed = 1, .tick_rate = 60, .changes_per_second = -1}, 0),
                 std::invalid_argument);
    EXPECT_THROW(Bot({.kind = BotKind::Random, .seed = 1, .tick_rate = 60, .changes_per_second = 61}, 0),
                 std::invalid_argument);
}

TEST(Bot, RandomWalkIsAPureFunctionOfSeedSlotAndFrame) {
    const sim::World world(room_with({}));
    const Bot a({.kind = BotKind::Random, .seed = 42}, 0);
    const Bot b({.kind = BotKind::Random, .seed = 42}, 0);
    std::vector<PlayerInput> forward;
    for (std::uint32_t f = 0; f < 3000; ++f) forward.push_back(a.input(f, world));
    // Any order, any instance: the same answer (a rollback re-asks for old frames).
    for (std::uint32_t f = 3000; f-- > 0;) EXPECT_EQ(b.input(f, world), forward[f]) << f;
    EXPECT_EQ(a.input(1234, world), forward[1234]);
}

TEST(Bot, SeedAndSlotChangeTheSequence) {
    const Bot base({.seed = 42}, 0), other_seed({.seed = 43}, 0), other_slot({.seed = 42}, 1);
    int differ_seed = 0, differ_slot = 0;
    for (std::uint32_t f = 0; f < 600; ++f) {
        differ_seed += !(base.random_walk(f) == other_seed.random_walk(f));
        differ_slot += !(base.random_walk(f) == other_slot.random_walk(f));
    }
    EXPECT_GT(differ_seed, 300);
    EXPECT_GT(differ_slot, 300);
}

namespace {
// Direction switches per second that a viewer can see (stick x/z changed from the frame before).
double visible_changes_per_second(const Bot& bot, std::uint32_t frames, int tick_rate) {
    int changes = 0;
    for (std::uint32_t f = 1; f < frames; ++f) {
        const PlayerInput a = bot.random_walk(f - 1), b = bot.random_walk(f);
        changes += (a.right != b.right || a.forward != b.forward);
    }
    return changes * static_cast<double>(tick_rate) / frames;
}
}  // namespace

TEST(Bot, RandomWalkChangesDirectionAtTheSetRate) {
    // A switch lands on the same stick position with probability 1/64 + 16 (7/128)^2 ~= 0.0635,
    // and a forced switch every 1024 frames adds ~0.06/s: visible rate ~= 0.94 * (rate + 0.06).
    constexpr std::uint32_t kFrames = 60 * 600;  // ten minutes at 60 Hz
    const double four = visible_changes_per_second(Bot({.seed = 7}, 0), kFrames, 60);
    EXPECT_NEAR(four, 0.9365 * (4.0 + 60.0 / 1024), 0.3);
    const double one = visible_changes_per_second(
        Bot({.kind = BotKind::Random, .seed = 7, .tick_rate = 60, .changes_per_second = 1.0}, 0), kFrames, 60);
    EXPECT_NEAR(one, 0.9365 * (1.0 + 60.0 / 1024), 0.15);
    // Rate 0: only the forced switches.
    const Bot still({.kind = BotKind::Random, .seed = 7, .tick_rate = 60, .changes_per_second = 0.0}, 0);
    for (std::uint32_t f = 1; f < 1024; ++f) EXPECT_EQ(still.random_walk(f).right, still.random_walk(0).right);
}

TEST(Bot, RandomWalkStaysInRangeMovesAndHopsBriefly) {
    const Bot bot({.seed = 3}, 0);
    int moving = 0, hop_run = 0, longest_hop = 0, hops = 0;
    for (std::uint32_t f = 0; f < 36'000; ++f) {
        const PlayerInput in = bot.random_walk(f);
        for (const std::int8_t axis : {in.forward, in.right, in.up}) {
            EXPECT_GE(axis, -127);
            EXPECT_LE(axis, 127);
        }
        moving += (in.right != 0 || in.forward != 0);
        if (in.up == 127) {
            hops += (hop_run == 0);
            longest_hop = std::max(longest_hop, ++hop_run);
        } else {
            EXPECT_EQ(in.up, 0);
            hop_run = 0;
        }
    }
    EXPECT_NEAR(moving / 36'000.0, 7.0 / 8.0, 0.05);
    EXPECT_GT(hops, 100);  // ~1 switch in 8 hops: ~300 in ten minutes
    EXPECT_LE(longest_hop, 12);  // 6 frames, or two hops back to back
}

TEST(Bot, SteerTowardPointsAtTheTarget) {
    const Vec3 o = v3(fx(1), fx(1), fx(1));
    EXPECT_EQ(steer_toward(o, o + v3(fx(3), fx(0), fx(0))), (PlayerInput{.forward = 0, .right = 127, .up = 0}));
    EXPECT_EQ(steer_toward(o, o + v3(fx(0), fx(0), fx(-3))), (PlayerInput{.forward = -127, .right = 0, .up = 0}));
    EXPECT_EQ(steer_toward(o, o + v3(fx(2), fx(0), fx(1))), (PlayerInput{.forward = 64, .right = 127, .up = 0}));
    EXPECT_EQ(steer_toward(o, o + v3(fx(-1), fx(0), fx(-1))), (PlayerInput{.forward = -127, .right = -127, .up = 0}));
    EXPECT_EQ(steer_toward(o, o + v3(fx(0), fx(2), fx(0))), (PlayerInput{.forward = 0, .right = 0, .up = 127}));
    EXPECT_EQ(steer_toward(o, o + v3(fx(0), fx(1), fx(0))).up, 0);  // exactly 1 m above: not yet
    EXPECT_EQ(steer_toward(o, o), PlayerInput{});
}

TEST(Bot, NearestBallIgnoresPlayersAndBreaksTiesByLowerId) {
    // Player box at the origin; balls at 3 m (+x), 2 m (-z), 2 m (+z, later id): nearest is the
    // first 2 m one. The sphere-shaped player 1 at 0.5 m is not a ball.
    const sim::SceneDesc scene =
        room_with({v3(fx(3), fx(9, 10), fx(0)), v3(fx(0), fx(9, 10), fx(-2)), v3(fx(0), fx(9, 10), fx(2))}, true);
    const sim::World world(scene);
    const sim::BodyId first_ball = 8;  // 6 walls, 2 players
    ASSERT_EQ(world.scene().bodies[first_ball].player, -1);
    EXPECT_EQ(nearest_ball(world, 0), first_ball + 1);
    EXPECT_EQ(nearest_ball(world, 5), std::nullopt);
    const sim::World empty(room_with({}));
    EXPECT_EQ(nearest_ball(empty, 0), std::nullopt);
}

TEST(Bot, ChaseSteersTowardTheNearestBallAndCatchesUp) {
    const sim::SceneDesc scene = room_with({v3(fx(6), fx(1, 4), fx(4))});
    sim::World world(scene);
    const sim::BodyId player = world.player_body(0);
    const sim::BodyId ball = 7;
    const Bot chaser({.kind = BotKind::Chase, .seed = 1}, 0);
    const PlayerInput first = chaser.input(0, world);
    EXPECT_EQ(first.right, 127);
    EXPECT_EQ(first.forward, 85);  // round(127 * 4 / 6)
    const Fixed start = distance(world, player, ball);
    for (std::uint32_t f = 0; f < 120; ++f) {
        const PlayerInput in[1] = {chaser.input(world.frame(), world)};
        world.step(in);
    }
    EXPECT_LT(distance(world, player, ball).raw, start.raw / 4) << distance(world, player, ball).to_string();
}

TEST(Bot, ChaseDependsOnWorldStateOnlyThroughPositions) {
    const Bot chaser({.kind = BotKind::Chase, .seed = 1}, 0);
    const sim::World left(room_with({v3(fx(-4), fx(1, 4), fx(0))}));
    const sim::World right(room_with({v3(fx(4), fx(1, 4), fx(0))}));
    EXPECT_EQ(chaser.input(10, left).right, -127);
    EXPECT_EQ(chaser.input(10, right).right, 127);
    EXPECT_EQ(chaser.input(10, right), chaser.input(99, right));  // frame does not matter when chasing
    // No ball: the chaser falls back to its random walk.
    const sim::World empty(room_with({}));
    for (std::uint32_t f = 0; f < 200; ++f) EXPECT_EQ(chaser.input(f, empty), chaser.random_walk(f));
}

TEST(Bot, SlotWithoutPlayerGetsNeutralInput) {
    const sim::World world(room_with({v3(fx(4), fx(1, 4), fx(0))}));
    EXPECT_EQ(Bot({.kind = BotKind::Chase, .seed = 1}, 3).input(0, world), PlayerInput{});
    EXPECT_EQ(Bot({.kind = BotKind::Random, .seed = 1}, 3).input(0, world), PlayerInput{});
}

TEST(Bot, PaperSceneChasersAreReproducible) {
    // Two chasers on the paper scene, run twice: identical worlds frame by frame.
    const sim::SceneDesc scene = load_scene("paper");
    const auto run = [&] {
        sim::World world(scene);
        const Bot bots[2] = {Bot({.kind = BotKind::Chase, .seed = 5}, 0), Bot({.kind = BotKind::Random, .seed = 5}, 1)};
        std::vector<PlayerInput> trace;
        for (int f = 0; f < 240; ++f) {
            const PlayerInput in[2] = {bots[0].input(world.frame(), world), bots[1].input(world.frame(), world)};
            trace.insert(trace.end(), in, in + 2);
            world.step(in);
        }
        return trace;
    };
    EXPECT_EQ(run(), run());
}

}  // namespace
}  // namespace lockroll::harness
