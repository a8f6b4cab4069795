// Sync test on every shipped scene (bodies_10k only a few frames), and proof that it catches a
// simulation that does not save all of its state.
#include <gtest/gtest.h>

#include "harness/match/scene_loader.h"
#include "rollback/sync_test.h"
#include "rollback/world_simulation.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

struct SceneCase {
    const char* scene;
    int frames;
    int distance;
};

class ShippedScene : public ::testing::TestWithParam<SceneCase> {};

TEST_P(ShippedScene, RollbackResimulationIsDeterministic) {
    const SceneCase c = GetParam();
    const sim::SceneDesc scene = harness::load_scene(c.scene);
    const int players = std::max(sim::player_count(scene), 1);
    WorldSimulation sim(scene, players);
    SyncTest test(sim, {players, kWorldInputSize, c.distance});
    std::vector<testing::WalkBot> bots;
    for (int p = 0; p < players; ++p) bots.emplace_back(100 + static_cast<std::uint64_t>(p));
    std::vector<std::uint8_t> inputs(static_cast<std::size_t>(players) * kWorldInputSize);
    for (int f = 0; f < c.frames; ++f) {
        for (int p = 0; p < players; ++p) {
            const auto in = bots[static_cast<std::size_t>(p)].next();
            std::copy(in.begin(), in.end(), inputs.begin() + p * 3);
        }
        const auto failure = test.advance(inputs);
        ASSERT_FALSE(failure.has_value()) << c.scene << ": frame " << failure->frame << " (rolled back from "
                                          << failure->loaded_frame << "): " << failure->detail;
    }
    EXPECT_EQ(test.frame(), static_cast<std::uint32_t>(c.frames));
    EXPECT_GT(test.resimulated_frames(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedScene,
                         ::testing::Values(SceneCase{"paper", 720, 8}, SceneCase{"paper", 200, 1},
                                           SceneCase{"bodies_1k", 60, 8}, SceneCase{"bodies_10k", 3, 2}),
                         [](const auto& info) {
                             return std::string(info.param.scene) + "_d" + std::to_string(info.param.distance);
                         });

// A World with a hidden counter that step() uses but save() does not store: forward runs are
// deterministic, but a rollback cannot restore the counter, so resimulation differs.
class LeakySimulation final : public Simulation {
public:
    explicit LeakySimulation(const sim::SceneDesc& scene) : inner_(scene, 2) {}
    using Simulation::step;
    void step(std::span<const std::uint8_t> inputs) override {
        ++steps_;
        if (steps_ == 40) inner_.flip_bit(10, 3, 20);  // the 40th call, forward or not
        inner_.step(inputs);
    }
    std::size_t state_size() const override { return inner_.state_size(); }
    void save(std::span<std::uint8_t> out) const override { inner_.save(out); }
    std::string load(std::span<const std::uint8_t> in) override { return inner_.load(in); }
    std::uint32_t body_count() const override { return inner_.body_count(); }
    std::uint32_t body_id(std::uint32_t i) const override { return inner_.body_id(i); }
    int field_count() const override { return inner_.field_count(); }
    const char* field_name(int f) const override { return inner_.field_name(f); }
    std::int64_t field_value(std::span<const std::uint8_t> s, std::uint32_t i, int f) const override {
        return inner_.field_value(s, i, f);
    }

private:
    WorldSimulation inner_;
    int steps_ = 0;
};

TEST(SyncTest, ReportsNondeterminismWithItsFrame) {
    LeakySimulation sim(testing::make_scene(2, 20));
    SyncTest test(sim, {2, 3, 4});
    std::vector<std::uint8_t> inputs(6, 0);
    std::optional<SyncTestFailure> failure;
    for (int f = 0; f < 50 && !failure; ++f) failure = test.advance(inputs);
    ASSERT_TRUE(failure.has_value());
    // Call 40 is frame 8's forward step (frame 1: 1 call; frame n >= 4: 1 + 4 calls).
    EXPECT_GE(failure->frame, 1u);
    EXPECT_LE(failure->frame, 10u);
    EXPECT_NE(failure->expected, failure->actual);
    EXPECT_NE(failure->detail.find("body 10 "), std::string::npos) << failure->detail;
}

TEST(SyncTest, RejectsBadDistance) {
    WorldSimulation sim(testing::make_scene(2, 2), 2);
    EXPECT_THROW(SyncTest(sim, {2, 3, 0}), std::invalid_argument);
    EXPECT_THROW(SyncTest(sim, {2, 3, 65}), std::invalid_argument);
}

}  // namespace
}  // namespace lockroll::rollback
