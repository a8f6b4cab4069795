// FramePacing (rollback/frame_pacing.h) on its own, over hand-fed links: advantages sampled and
// clipped, only pacing peers counted, one wait per window, the tick stretch.
#include "rollback/frame_pacing.h"

#include <gtest/gtest.h>

#include <vector>

namespace lockroll::rollback {
namespace {

struct Fixture {
    SessionConfig config;
    std::vector<PeerLink> links;
    std::vector<std::int32_t> local;
    std::vector<PeerStats> stats;
    FramePacing pacing{config};
    FramePacing::Paces paces = [](PlayerId p) { return p != 0 && p != 3; };  // 0: us, 3: not live

    Fixture() {
        config.time_sync_window = 4;
        config.prediction_window = 8;
        config.time_sync_min_frames = 2;
        for (int p = 0; p < 4; ++p) links.emplace_back(10, config.time_sync_window);
        local.assign(4, 0);
        stats.resize(4);
    }
    // Peer p said at `at_us` it was at `frame`, and that it is `remote_adv` frames ahead of us.
    void report(PlayerId p, std::uint32_t frame, std::int8_t remote_adv, std::uint64_t at_us) {
        links[p].note_remote_frame(frame, remote_adv, at_us);
    }
};

TEST(FramePacing, SamplesEstimatedAdvantageClippedAndOnlyForPacingPeers) {
    Fixture f;
    f.report(1, 100, 0, 0);
    f.report(2, 5000, 0, 0);  // a forged frame far ahead
    f.report(3, 200, 0, 0);
    f.pacing.sample(f.links, f.paces, 90, 2, 50'000, f.local, f.stats);  // 50 ms: 3 frames at 60 Hz
    EXPECT_EQ(f.local[1], 13);
    EXPECT_EQ(f.local[2], f.pacing.advantage_bound(2)) << "clipped";
    EXPECT_EQ(f.local[3], 0) << "not a pacing peer";
    EXPECT_EQ(f.stats[1].frame_advantage_x100, 1300);
    EXPECT_EQ(f.pacing.behind(f.links, f.paces, 90, 50'000), 4913) << "behind() is not clipped";
}

TEST(FramePacing, ASilentPeerIsNotAssumedToRunOn) {
    Fixture f;
    f.report(1, 100, 0, 0);
    EXPECT_EQ(f.pacing.behind(f.links, f.paces, 100, f.config.interrupt_us), 45);
    EXPECT_EQ(f.pacing.behind(f.links, f.paces, 100, 100 * f.config.interrupt_us), 45);
}

TEST(FramePacing, OneWaitPerWindowFromFreshSamples) {
    Fixture f;
    // We are 3 frames ahead of peer 1: local -3, remote +3, a full window of samples.
    for (int i = 0; i < f.config.time_sync_window; ++i) f.links[1].time_sync().add_sample(-3, 3);
    EXPECT_EQ(f.pacing.frames_ahead_x100(f.links, f.paces), 300);
    EXPECT_EQ(f.pacing.recommend_wait(f.links, f.paces, 10, 2), 3);
    EXPECT_EQ(f.pacing.frames_ahead_x100(f.links, f.paces), 0) << "samples cleared";
    for (int i = 0; i < f.config.time_sync_window; ++i) f.links[1].time_sync().add_sample(-3, 3);
    EXPECT_EQ(f.pacing.recommend_wait(f.links, f.paces, 13, 2), 0) << "within the window";
    EXPECT_EQ(f.pacing.recommend_wait(f.links, f.paces, 14, 2), 3);
    // Never more than input delay + prediction window + 2.
    for (int i = 0; i < f.config.time_sync_window; ++i) f.links[1].time_sync().add_sample(-50, 50);
    EXPECT_EQ(f.pacing.recommend_wait(f.links, f.paces, 100, 0), 10);
}

TEST(FramePacing, TickStretchTwoPercentPerFrameCapped) {
    EXPECT_EQ(FramePacing::tick_stretch_ppm(50), 0);
    EXPECT_EQ(FramePacing::tick_stretch_ppm(100), 20'000);
    EXPECT_EQ(FramePacing::tick_stretch_ppm(100'000), kMaxTickStretchPpm);
}

}  // namespace
}  // namespace lockroll::rollback
