// Scene files: exact decimal parsing, and bad files rejected with a message naming the file,
// the place and the problem, without a half-loaded scene.
#include <gtest/gtest.h>

#include <string>

#include "harness/match/scene_loader.h"
#include "sim/world.h"

namespace lockroll::harness {
namespace {

std::string error_of(const std::string& text) {
    try {
        parse_scene(text, "test.json");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

TEST(SceneLoader, ShippedScenesLoad) {
    for (const char* name : {"paper", "bodies_1k", "bodies_10k"}) {
        const sim::SceneDesc s = load_scene(name);
        EXPECT_EQ(s.name, name);
        EXPECT_EQ(sim::validate(s), "");
    }
    const sim::SceneDesc paper = load_scene("paper");
    EXPECT_EQ(paper.bodies.size(), 6u + 2u + 50u);
    EXPECT_EQ(sim::player_count(paper), 2);
    EXPECT_EQ(load_scene("bodies_10k").bodies.size(), 6u + 10000u);
}

TEST(SceneLoader, DecimalsGoStraightToFixedPoint) {
    const sim::SceneDesc s = parse_scene(R"({"gravity": [0.1, -9.81, 1e-3],
        "bodies": [{"shape": "sphere", "position": [0, 1.5, 0], "radius": 0.25, "mass": 2}]})",
                                         "t.json");
    EXPECT_EQ(s.gravity.x, *sim::Fixed::parse("0.1"));
    EXPECT_EQ(s.gravity.y, *sim::Fixed::parse("-9.81"));
    EXPECT_EQ(s.gravity.z, *sim::Fixed::parse("0.001"));
    EXPECT_EQ(s.bodies[0].radius.raw, sim::Fixed::kOne / 4);
    // Digits beyond double precision still count: these differ in the 20th digit, which
    // Q32.32 resolves (1e-10 > 2^-33) but a round trip through double would not.
    const sim::SceneDesc a = parse_scene(R"({"gravity": [0, 1.00000000012, 0]})", "a");
    const sim::SceneDesc b = parse_scene(R"({"gravity": [0, 1.00000000035, 0]})", "b");
    EXPECT_NE(a.gravity.y, b.gravity.y);
}

TEST(SceneLoader, SyntaxErrorNamesFileLineAndColumn) {
    const std::string e = error_of("{\n  \"tick_rate\": 60,\n  \"iterations\": ,\n}");
    EXPECT_NE(e.find("test.json"), std::string::npos) << e;
    EXPECT_NE(e.find("line 3"), std::string::npos) << e;
}

// nlohmann refuses 1e400 before our decimal reader sees it; that must still be a SceneError
// with the place, not an escaping json::out_of_range (issue 11).
TEST(SceneLoader, NumbersBeyondADoubleAreLocated) {
    for (const char* n : {"1e400", "-1e400"}) {
        const std::string e = error_of(std::string("{\"gravity\": [0,\n  ") + n + ", 0]}");
        EXPECT_NE(e.find("test.json: line 2, column 3: number " + std::string(n) + " is outside the Q32.32 range"),
                  std::string::npos)
            << e;
    }
}

TEST(SceneLoader, BodyLimitIsCheckedBeforeSpawning) {
    set_max_scene_bodies(20);
    const std::string room = R"("room": {"min": [-5, 0, -5], "max": [5, 5, 5]})";
    const std::string ball = R"({"shape": "sphere", "position": [0, 1, 0], "radius": 0.2})";
    const std::string spawner =
        R"({"count": 14, "shape": "sphere", "radius": 0.2, "region": {"min": [-5, 0, -5], "max": [5, 5, 5]}})";
    EXPECT_EQ(parse_scene("{" + room + R"(, "spawners": [)" + spawner + "]}", "t").bodies.size(), 20u);
    const std::string over = error_of("{" + room + R"(, "bodies": [)" + ball + R"(], "spawners": [)" + spawner + "]}");
    EXPECT_NE(over.find("/spawners/0/count: the scene would have 21 bodies, more than the limit of 20"), std::string::npos)
        << over;
    const std::string many = error_of(R"({"spawners": [)" + spawner + "," + spawner + "]}");
    EXPECT_NE(many.find("/spawners/1/count: the scene would have 28 bodies"), std::string::npos) << many;
    set_max_scene_bodies(kDefaultMaxSceneBodies);
}

TEST(SceneLoader, SemanticErrorsNameThePlace) {
    struct Case {
        const char* text;
        const char* place;
        const char* problem;
    } cases[] = {
        {R"({"tick_rate": 0})", "/tick_rate", "[1, 1000]"},
        {R"({"tickrate": 60})", "/", "unknown key \"tickrate\""},
        {R"({"bodies": [{"shape": "cube", "position": [0,0,0]}]})", "/bodies/0/shape", "unknown shape"},
        {R"({"bodies": [{"shape": "sphere", "position": [0,0,0], "radius": -1}]})", "/bodies/0/radius", "> 0"},
        {R"({"bodies": [{"shape": "sphere", "position": [0,0], "radius": 1}]})", "/bodies/0/position", "3 numbers"},
        {R"({"bodies": [{"shape": "sphere", "radius": 1}]})", "/bodies/0", "missing required key \"position\""},
        {R"({"gravity": [0, 1e12, 0]})", "/gravity/1", "outside the Q32.32 range"},
        {R"({"gravity": [0, 3000000000, 0]})", "/gravity/1", "outside the Q32.32 range"},
        {R"({"restitution": {"sphere-sphere": 1.5}})", "/restitution/sphere-sphere", "[0, 1]"},
        {R"({"restitution": {"sphere": 1}})", "/restitution/sphere", "SHAPE-SHAPE"},
        {R"({"room": {"min": [1,1,1], "max": [0,2,2]}})", "/room", "below max"},
        {R"({"spawners": [{"count": 5, "shape": "sphere", "radius": 0.1, "region": {"min": [0,0,0], "max": [1,1,1]}, "seed": -4}]})",
         "/spawners/0/seed", "non-negative"},
        {R"({"bodies": [{"shape": "sphere", "position": [0,0,0], "radius": 1, "mass": 1, "player": 1}]})", "/",
         "player slots"},
        {R"({"bodies": [{"shape": "sphere", "position": [0,0,0], "radius": 1, "material": "rubber"}]})",
         "/bodies/0/material", "no material named"},
    };
    for (const Case& c : cases) {
        const std::string e = error_of(c.text);
        EXPECT_NE(e.find(std::string("test.json: ") + c.place), std::string::npos) << c.text << "\n -> " << e;
        EXPECT_NE(e.find(c.problem), std::string::npos) << c.text << "\n -> " << e;
    }
}

TEST(SceneLoader, MaterialsAndRestitutionTable) {
    const sim::SceneDesc s = parse_scene(R"({
        "restitution": {"capsule-sphere": 0.5},
        "materials": {"rubber": {"restitution": 0.9}},
        "bodies": [{"shape": "sphere", "position": [0,0,0], "radius": 1, "material": "rubber"}]})",
                                         "m.json");
    EXPECT_EQ(s.restitution[2][0], *sim::Fixed::parse("0.5"));
    EXPECT_EQ(s.restitution[0][2], *sim::Fixed::parse("0.5"));
    ASSERT_TRUE(s.bodies[0].restitution.has_value());
    EXPECT_EQ(*s.bodies[0].restitution, *sim::Fixed::parse("0.9"));
}

TEST(SceneLoader, MissingFileAndUnknownName) {
    EXPECT_THROW(load_scene_file("/nonexistent/scene.json"), SceneError);
    try {
        resolve_scene("no_such_scene");
        FAIL();
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("no_such_scene"), std::string::npos);
    }
}

TEST(SceneLoader, SpawnerIsDeterministic) {
    const char* text = R"({"spawners": [{"count": 20, "shape": "sphere", "radius": 0.1, "mass": 1,
        "region": {"min": [0,0,0], "max": [3,3,3]}, "max_speed": 2, "seed": 99}]})";
    const sim::SceneDesc a = parse_scene(text, "a"), b = parse_scene(text, "b");
    ASSERT_EQ(a.bodies.size(), 20u);
    for (std::size_t i = 0; i < a.bodies.size(); ++i) {
        EXPECT_EQ(a.bodies[i].position, b.bodies[i].position);
        EXPECT_EQ(a.bodies[i].velocity, b.bodies[i].velocity);
    }
    EXPECT_NE(a.bodies[0].position, a.bodies[1].position);
}

TEST(SceneLoader, RigidScenesReadOrientationFrictionAndDamping) {
    const sim::SceneDesc s = parse_scene(R"({"rigid": {"friction": {"sphere-box": 0.3}, "static_friction": 0.6,
        "angular_damping": 0.1, "shock_propagation": true, "warm_starting": true, "split_impulse": true,
        "reduce_manifold": true, "block_solver": true, "graph_colouring": true},
        "bodies": [{"shape": "box", "position": [0, 0, 0], "half_extents": [1, 1, 1], "orientation": [0.5, 0.5, 0.5, 0.5]},
                   {"shape": "sphere", "position": [0, 3, 0], "radius": 0.5, "mass": 1, "angular_velocity": [0, 2, 0],
                    "friction": 0.9, "linear_damping": 0.5}]})",
                                         "t.json");
    EXPECT_TRUE(s.rigid.enabled);
    EXPECT_TRUE(s.rigid.shock_propagation);
    EXPECT_TRUE(s.rigid.warm_starting);
    EXPECT_TRUE(s.rigid.split_impulse);
    EXPECT_TRUE(s.rigid.reduce_manifold);
    EXPECT_TRUE(s.rigid.block_solver);
    EXPECT_TRUE(s.rigid.graph_colouring);
    EXPECT_FALSE(load_scene("paper_rigid").rigid.warm_starting);  // opt-in
    EXPECT_FALSE(load_scene("paper_rigid").rigid.graph_colouring);
    EXPECT_TRUE(load_scene("bodies_10k_rigid").rigid.graph_colouring);
    EXPECT_FALSE(load_scene("paper_rigid").rigid.split_impulse || load_scene("paper_rigid").rigid.reduce_manifold ||
                 load_scene("paper_rigid").rigid.block_solver);
    EXPECT_EQ(s.rigid.friction[0][1], *sim::Fixed::parse("0.3"));
    EXPECT_EQ(s.rigid.friction[1][0], *sim::Fixed::parse("0.3"));
    EXPECT_EQ(s.rigid.friction[1][1], *sim::Fixed::parse("0.5"));  // the default for pairs not named
    EXPECT_EQ(s.rigid.static_friction[2][2], *sim::Fixed::parse("0.6"));
    EXPECT_EQ(s.bodies[0].orientation.x, *sim::Fixed::parse("0.5"));
    EXPECT_EQ(s.bodies[1].angular_velocity.y, sim::Fixed::from_int(2));
    EXPECT_EQ(*s.bodies[1].friction, *sim::Fixed::parse("0.9"));
    EXPECT_EQ(*s.bodies[1].linear_damping, *sim::Fixed::parse("0.5"));
    for (const char* name : {"paper_rigid", "bodies_1k_rigid", "bodies_10k_rigid"})
        EXPECT_TRUE(load_scene(name).rigid.enabled) << name;
}

// bodies_1k_rigid is bodies_10k_rigid at a tenth of the bodies and the same density: a tenth of
// each shape with the same sizes and materials, a tenth of the floor area (so the pile is as
// deep), the same room height and spawn heights.
TEST(SceneLoader, Bodies1kRigidIsThe10kRecipeAtATenth) {
    const sim::SceneDesc small = load_scene("bodies_1k_rigid"), large = load_scene("bodies_10k_rigid");
    const auto count = [](const sim::SceneDesc& s, sim::Shape shape) {
        std::size_t n = 0;
        for (const auto& b : s.bodies) n += b.mass.raw > 0 && b.shape == shape;
        return n;
    };
    for (sim::Shape shape : {sim::Shape::Sphere, sim::Shape::Box}) {
        EXPECT_GT(count(small, shape), 0u);
        EXPECT_EQ(count(small, shape) * 10, count(large, shape));
    }
    const auto first = [](const sim::SceneDesc& s, sim::Shape shape) {
        for (const auto& b : s.bodies)
            if (b.mass.raw > 0 && b.shape == shape) return b;
        return sim::BodyDesc{};
    };
    EXPECT_EQ(first(small, sim::Shape::Sphere).radius, first(large, sim::Shape::Sphere).radius);
    EXPECT_EQ(first(small, sim::Shape::Box).half_extents, first(large, sim::Shape::Box).half_extents);
    EXPECT_EQ(small.rigid.friction[0][0], large.rigid.friction[0][0]);
    EXPECT_EQ(small.iterations, large.iterations);
    const auto to_d = [](sim::Fixed f) { return static_cast<double>(f.raw) / static_cast<double>(sim::Fixed::kOne); };
    // The room's walls come first (sim::add_room): the floor, then the ceiling. The floor spans
    // the inside plus a wall thickness (twice its half height) on each side.
    ASSERT_GE(small.bodies.size(), 2u);
    ASSERT_GE(large.bodies.size(), 2u);
    const auto floor_per_body = [&](const sim::SceneDesc& s) {
        const sim::BodyDesc& f = s.bodies[0];
        const double t = 2 * to_d(f.half_extents.y);
        const double dx = 2 * to_d(f.half_extents.x) - 2 * t, dz = 2 * to_d(f.half_extents.z) - 2 * t;
        return dx * dz / static_cast<double>(count(s, sim::Shape::Sphere) + count(s, sim::Shape::Box));
    };
    EXPECT_NEAR(floor_per_body(small), floor_per_body(large), 0.01 * floor_per_body(large));
    EXPECT_EQ(small.bodies[1].position.y, large.bodies[1].position.y);  // the ceiling
}

TEST(SceneLoader, RigidKeysOutsideARigidSceneAreErrors) {
    EXPECT_EQ(error_of(R"({"bodies": [{"shape": "sphere", "position": [0, 0, 0], "radius": 1, "mass": 1,
        "angular_velocity": [1, 0, 0]}]})"),
              "test.json: /bodies/0/angular_velocity: needs a rigid scene (top-level \"rigid\")");
    EXPECT_EQ(error_of(R"({"rigid": true, "bodies": [{"shape": "sphere", "position": [0, 0, 0], "radius": 1,
        "orientation": [0, 0, 0, 0]}]})"),
              "test.json: /bodies/0/orientation: must not be zero");
    EXPECT_EQ(error_of(R"({"rigid": {"friction": {"sphere-cone": 1}}})"),
              "test.json: /rigid/friction/sphere-cone: key must be SHAPE-SHAPE with shapes sphere, box, capsule");
    EXPECT_EQ(error_of(R"({"rigid": {"friction": 11}})"), "test.json: /rigid/friction: must be within [0, 10], got 11");
    EXPECT_EQ(error_of(R"({"rigid": {"warm_starting": 1}})"), "test.json: /rigid/warm_starting: expected true or false");
    EXPECT_EQ(error_of(R"({"rigid": {"graph_colouring": 1}})"), "test.json: /rigid/graph_colouring: expected true or false");
    EXPECT_EQ(error_of(R"({"rigid": true, "solver": {"substeps": 2}})"),
              "test.json: /: rigid scenes use their own solver: drop the \"solver\" settings");
}

TEST(SceneLoader, RigidSleepingReadsItsThresholdsAndRejectsBadOnes) {
    EXPECT_FALSE(load_scene("bodies_10k_rigid").rigid.sleeping.enabled);  // opt-in
    const sim::SceneDesc on = parse_scene(R"({"rigid": {"sleeping": true}})", "t.json");
    EXPECT_TRUE(on.rigid.sleeping.enabled);
    EXPECT_EQ(on.rigid.sleeping.linear_speed, *sim::Fixed::parse("0.05"));
    EXPECT_EQ(on.rigid.sleeping.time, *sim::Fixed::parse("0.5"));
    const sim::SceneDesc set =
        parse_scene(R"({"rigid": {"sleeping": {"linear_speed": 0.1, "angular_speed": 0.2, "time": 2}}})", "t.json");
    EXPECT_TRUE(set.rigid.sleeping.enabled);
    EXPECT_EQ(set.rigid.sleeping.linear_speed, *sim::Fixed::parse("0.1"));
    EXPECT_EQ(set.rigid.sleeping.angular_speed, *sim::Fixed::parse("0.2"));
    EXPECT_EQ(set.rigid.sleeping.time, sim::Fixed::from_int(2));
    EXPECT_EQ(error_of(R"({"rigid": {"sleeping": {"time": 61}}})"), "test.json: /rigid/sleeping/time: must be within [0, 60], got 61");
    EXPECT_EQ(error_of(R"({"rigid": {"sleeping": {"linear_speed": 0}}})"),
              "test.json: /: rigid.sleeping.linear_speed must be within (0, 100]");
    EXPECT_EQ(error_of(R"({"rigid": {"sleeping": {"angular_speed": -1}}})"),
              "test.json: /rigid/sleeping/angular_speed: must be within [0, 100], got -1");
    EXPECT_EQ(error_of(R"({"rigid": {"sleeping": {"speed": 1}}})").find("test.json: /rigid/sleeping"), 0u);
}

// rigid.spinning_friction and rigid.rolling_friction: metres, absent = 0 (off).
TEST(SceneLoader, RigidSpinningAndRollingFrictionReadAsMetresAndRejectBadOnes) {
    const sim::SceneDesc off = parse_scene(R"({"rigid": true})", "t.json");
    EXPECT_EQ(off.rigid.spinning_friction, sim::Fixed::zero());
    EXPECT_EQ(off.rigid.rolling_friction, sim::Fixed::zero());
    const sim::SceneDesc on = parse_scene(R"({"rigid": {"spinning_friction": 0.02, "rolling_friction": 0.005}})", "t.json");
    EXPECT_EQ(on.rigid.spinning_friction, *sim::Fixed::parse("0.02"));
    EXPECT_EQ(on.rigid.rolling_friction, *sim::Fixed::parse("0.005"));
    EXPECT_EQ(error_of(R"({"rigid": {"spinning_friction": -1}})"),
              "test.json: /rigid/spinning_friction: must be within [0, 1], got -1");
    EXPECT_EQ(error_of(R"({"rigid": {"rolling_friction": 2}})"),
              "test.json: /rigid/rolling_friction: must be within [0, 1], got 2");
    EXPECT_EQ(error_of(R"({"rigid": {"rolling_friction": "x"}})"), "test.json: /rigid/rolling_friction: expected a number");
}

}  // namespace
}  // namespace lockroll::harness
