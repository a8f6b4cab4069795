// The stability suite (its cases as a library, its command), the precision sweep's checks before
// work, and the opt-in solver features they rely on (docs/stability.md).
// The suite's cases themselves run as CTest tests of `lockroll stability --case NAME`
// (tests/harness/stability.cmake); these tests pin down what the cases cannot see.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/match/cli_error.h"
#include "harness/match/scene_loader.h"
#include "harness/stability_command.h"
#include "harness/validation/precision_sweep.h"
#include "harness/validation/reference_world.h"
#include "harness/validation/stability_cases.h"
#include "sim/snapshot.h"
#include "sim/step_kernel.h"
#include "sim/world.h"

namespace lockroll {
namespace {

sim::SceneDesc paper_without_players() {
    sim::SceneDesc s = harness::load_scene("paper");
    std::vector<sim::BodyDesc> kept;
    for (const auto& b : s.bodies)
        if (b.player < 0) kept.push_back(b);
    s.bodies = kept;
    return s;
}

void expect_same_state(const sim::World& a, const sim::World& b) {
    ASSERT_EQ(a.body_count(), b.body_count());
    for (sim::BodyId id : a.dynamic_ids()) {
        ASSERT_EQ(a.position(id), b.position(id)) << "body " << id;
        ASSERT_EQ(a.velocity(id), b.velocity(id)) << "body " << id;
    }
}

TEST(SolverSettings, ShippedScenesKeepTheDefaultPath) {
    for (const char* name : {"paper", "bodies_1k", "bodies_10k"}) {
        const sim::SceneDesc s = harness::load_scene(name);
        EXPECT_TRUE(s.solver.is_default()) << name;
        EXPECT_FALSE(sim::World(s).kernel().extended()) << name;
    }
}

TEST(SolverSettings, AnyNonDefaultValueSelectsTheExtendedPath) {
    sim::SceneDesc s = paper_without_players();
    s.solver.slop = sim::Fixed::from_raw(1);
    EXPECT_TRUE(sim::World(s).kernel().extended());
    s.solver = sim::SolverDesc{};
    s.solver.continuous = true;
    EXPECT_TRUE(sim::World(s).kernel().extended());
}

// Substeps are the step run with dt / substeps: with nothing else opted in (and no players,
// whose input arrives once per frame), 60 Hz x 2 substeps must equal 120 Hz bit for bit. This
// ties the extended path to the default one operation for operation.
TEST(SolverSettings, SubstepsEqualAHigherTickRate) {
    sim::SceneDesc fine = paper_without_players(), coarse = fine;
    fine.tick_rate = 120;
    coarse.tick_rate = 60;
    coarse.solver.substeps = 2;
    sim::World wf(fine), wc(coarse);
    ASSERT_FALSE(wf.kernel().extended());
    ASSERT_TRUE(wc.kernel().extended());
    for (int f = 0; f < 240; ++f) {
        wc.step({});
        wf.step({});
        wf.step({});
    }
    expect_same_state(wf, wc);
}

TEST(SolverSettings, LoaderReadsAndChecksTheSolverObject) {
    const sim::SceneDesc s = harness::parse_scene(
        R"({"solver": {"substeps": 4, "integrator": "ballistic", "slop": 0.001, "max_push_speed": 3,
            "restitution_threshold": 0.5, "restitution_after": true, "position_based": true,
            "shock_propagation": true, "continuous": true, "continuous_min_speed": 0.25},
            "bodies": [{"shape": "sphere", "position": [0, 1, 0], "radius": 0.5, "mass": 1}]})",
        "inline");
    EXPECT_EQ(s.solver.substeps, 4);
    EXPECT_EQ(s.solver.integrator, sim::Integrator::Ballistic);
    EXPECT_EQ(s.solver.slop, *sim::Fixed::parse("0.001"));
    EXPECT_EQ(s.solver.max_push_speed, sim::Fixed::from_int(3));
    EXPECT_TRUE(s.solver.restitution_after && s.solver.position_based && s.solver.shock_propagation && s.solver.continuous);
    EXPECT_EQ(s.solver.continuous_min_speed, *sim::Fixed::parse("0.25"));

    auto error_of = [](const std::string& solver) {
        try {
            harness::parse_scene(R"({"solver": )" + solver + "}", "inline");
        } catch (const harness::SceneError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(error_of(R"({"substep": 2})").find("unknown key \"substep\""), std::string::npos);
    EXPECT_NE(error_of(R"({"substeps": 0})").find("/solver/substeps"), std::string::npos);
    EXPECT_NE(error_of(R"({"integrator": "rk4"})").find("/solver/integrator"), std::string::npos);
    EXPECT_NE(error_of(R"({"correction": 0})").find("/solver/correction"), std::string::npos);
    EXPECT_NE(error_of(R"({"continuous": 1})").find("expected true or false"), std::string::npos);
    EXPECT_NE(error_of(R"({"shock_propagation": true})").find("slop"), std::string::npos);
}

// The extended path keeps nothing between steps that a snapshot does not hold.
TEST(SolverSettings, ExtendedScenesResumeFromSnapshotsExactly) {
    for (const char* name : {"stability/resting_pile", "stability/tunneling", "stability/bounce_e08", "stability/mass_ratio"}) {
        const sim::SceneDesc s = harness::load_scene(name);
        sim::World a(s), b(s);
        for (int f = 0; f < 90; ++f) {
            a.step({});
            b.step({});
        }
        std::vector<std::uint8_t> snap(sim::snapshot_size(a));
        sim::save(a, snap);
        for (int f = 0; f < 30; ++f) a.step({});
        ASSERT_EQ(sim::load(a, snap), "") << name;
        for (int f = 0; f < 60; ++f) {
            a.step({});
            b.step({});
        }
        expect_same_state(a, b);
        EXPECT_EQ(sim::checksum(a), sim::checksum(b)) << name;
    }
}

// The double reference runs the same algorithm: on a non-chaotic case it must track the
// Q32.32 world to within rounding, whatever path the scene takes.
TEST(ReferenceWorld, TracksTheFixedPointWorld) {
    for (const char* name : {"stability/precision_ball", "stability/precision_stack", "stability/bounce_e08", "stability/mass_ratio"}) {
        const sim::SceneDesc s = harness::load_scene(name);
        sim::World w(s);
        harness::ReferenceWorld r(s);
        double worst = 0;
        for (int f = 0; f < 120; ++f) {
            w.step({});
            r.step();
            for (sim::BodyId id : w.dynamic_ids()) {
                const auto& p = w.position(id);
                const auto& q = r.position(id);
                auto d = [](sim::Fixed a, double b) { return std::fabs(std::ldexp(static_cast<double>(a.raw), -32) - b); };
                worst = std::max({worst, d(p.x, q.x), d(p.y, q.y), d(p.z, q.z)});
            }
        }
        EXPECT_LT(worst, 1e-6) << name;
    }
}

// The extended path never divides by zero or saturates in ordinary scenes: every operation that
// does is counted, so the overflow counter must stay at 0 (touching boxes once divided 0 / 0 in
// the continuous sweep; the double reference turned that into NaN).
TEST(SolverSettings, StabilityScenesNeverSaturate) {
    for (const char* name : {"stability/free_fall", "stability/bounce_e1", "stability/bounce_e08", "stability/head_on",
                             "stability/newton_cradle", "stability/stack_24", "stability/mass_ratio",
                             "stability/overlap_spawn", "stability/tunneling", "stability/far_origin",
                             "stability/tiny_huge", "stability/resting_pile", "stability/precision_stack"}) {
        sim::SceneDesc s = harness::load_scene(name);
        for (bool exact : {false, true}) {
            if (exact) {
                s.solver.integrator = sim::Integrator::Ballistic;
                s.solver.continuous = true;
            }
            sim::World w(s);
            for (int f = 0; f < 180; ++f) w.step({});
            EXPECT_EQ(w.overflow_count(), 0u) << name << (exact ? " with ballistic+continuous" : "");
        }
    }
}

TEST(ReferenceWorld, StaysFiniteAndCloseWithExactStatics) {
    sim::SceneDesc s = harness::load_scene("stability/precision_stack");
    s.solver.integrator = sim::Integrator::Ballistic;
    s.solver.continuous = true;
    sim::World w(s);
    harness::ReferenceWorld r(s);
    for (int f = 0; f < 180; ++f) {
        w.step({});
        r.step();
    }
    for (sim::BodyId id : w.dynamic_ids()) {
        ASSERT_TRUE(std::isfinite(r.position(id).y)) << id;
        EXPECT_NEAR(std::ldexp(static_cast<double>(w.position(id).y.raw), -32), r.position(id).y, 1e-6) << id;
    }
}

TEST(ReferenceWorld, RefusesPlayers) {
    EXPECT_THROW(harness::ReferenceWorld(harness::load_scene("paper")), std::invalid_argument);
}

int run_cli(const std::vector<std::string>& args) {
    CLI::App app;
    harness::add_stability_command(app);
    std::vector<const char*> argv{"lockroll"};
    for (const auto& a : args) argv.push_back(a.c_str());
    app.parse(static_cast<int>(argv.size()), const_cast<char**>(argv.data()));
    return 0;
}

TEST(StabilityCommand, UnknownCaseIsAUsageError) {
    try {
        run_cli({"stability", "--case", "no_such_case"});
        FAIL() << "expected a usage error";
    } catch (const harness::UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("no_such_case"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("head_on"), std::string::npos);  // lists the known cases
    }
}

TEST(StabilityCommand, WritesTheFiguresAsJson) {
    const auto path = std::filesystem::temp_directory_path() / "lockroll_stability_test.json";
    std::filesystem::remove(path);
    run_cli({"stability", "--case", "head_on", "--case", "far_origin", "--json", path.string()});
    std::ifstream in(path);
    const auto j = nlohmann::json::parse(in);
    ASSERT_EQ(j.size(), 2u);
    EXPECT_EQ(j[0]["case"], "head_on");
    EXPECT_EQ(j[0]["result"], "PASS");
    EXPECT_FALSE(j[0]["checks"].empty());
    EXPECT_TRUE(j[0]["checks"][0].contains("figure"));
    EXPECT_EQ(j[1]["case"], "far_origin");
    std::filesystem::remove(path);
}

// The suite as a library (harness/validation/stability_cases.h), without the command: names
// unique (the command finds a case by name), and a case run directly gives checked criteria.
TEST(StabilityCases, NamesAreUniqueAndACaseRunsWithoutTheCommand) {
    const auto cases = harness::stability::all_cases();
    std::set<std::string> names;
    for (const auto& c : cases) EXPECT_TRUE(names.insert(c.name).second) << c.name;
    EXPECT_EQ(cases.front().name, "free_fall");
    const auto head_on = std::find_if(cases.begin(), cases.end(), [](const auto& c) { return c.name == "head_on"; });
    ASSERT_NE(head_on, cases.end());
    const harness::stability::Outcome r = head_on->run();
    EXPECT_TRUE(r.pass());
    EXPECT_TRUE(std::any_of(r.checks.begin(), r.checks.end(), [](const auto& k) { return !k.criterion.empty(); }));
}

// The sweep checks its output directory before any work: one below a regular file cannot be.
TEST(PrecisionSweep, AnUnusableOutDirIsAUsageErrorBeforeAnyWork) {
    const auto file = std::filesystem::temp_directory_path() / "lockroll_precision_sweep_test_file";
    std::ofstream(file) << "not a directory\n";
    harness::PrecisionOptions o;
    o.out = (file / "out").string();
    o.quick = true;
    o.no_plot = true;
    EXPECT_THROW(harness::run_precision_sweep(o), harness::UsageError);
    EXPECT_FALSE(std::filesystem::exists(file / "out"));
    std::filesystem::remove(file);
}

}  // namespace
}  // namespace lockroll
