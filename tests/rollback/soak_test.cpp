// Long runs under the harsh network goal (label "soak": excluded from the default test
// run; `ctest -L soak` runs them). They check the session core alone, over the in-test network.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;
using testing::NetParams;

void expect_all_agree(Cluster& cluster, std::uint32_t frames) {
    const Replay& first = cluster.clients[0]->recorder.replay();
    for (const auto& c : cluster.clients) {
        const Replay& r = c->recorder.replay();
        ASSERT_GE(r.frames(), frames);
        for (std::uint32_t f = 0; f < frames; ++f) ASSERT_EQ(r.checksums[f], first.checksums[f]) << "frame " << f + 1;
        EXPECT_TRUE(c->desyncs.empty());
        for (const auto& p : c->session->stats().peers) EXPECT_EQ(p.checksum_mismatches, 0u);
    }
}

// 150 +- 50 ms one way, 20 % loss, 5 % duplication, 10 % reordering, 8 players, 10 minutes.
TEST(Soak, EightPlayersTenMinutesHarshNetwork) {
    const auto scene = make_scene(8, 50);
    SessionConfig cfg;
    cfg.players = 8;
    cfg.input_delay = 3;
    NetParams net;
    net.latency_us = 100000;
    net.jitter_us = 100000;
    net.loss_ppm = 200000;
    net.duplicate_ppm = 50000;
    net.reorder_ppm = 100000;
    if (const char* w = std::getenv("SOAK_TS_WINDOW")) cfg.time_sync_window = std::atoi(w);
    if (const char* m = std::getenv("SOAK_TS_MIN")) cfg.time_sync_min_frames = std::atoi(m);
    if (const char* d = std::getenv("SOAK_DELAY")) cfg.input_delay = std::atoi(d);
    Cluster cluster(scene, cfg, net, 2024);
    const std::uint32_t frames = std::getenv("SOAK_FRAMES") ? static_cast<std::uint32_t>(std::atoi(std::getenv("SOAK_FRAMES"))) : 36000;
    cluster.run_frames(frames, 3600'000'000);
    cluster.settle(frames);
    expect_all_agree(cluster, frames);
    WorldSimulation reference(scene, 8);
    const auto mismatch = verify_replay(cluster.clients[3]->recorder.replay(), reference);
    EXPECT_FALSE(mismatch.has_value());
    const auto& st = cluster.clients[0]->session->stats();
    std::printf("8 players, %u frames in %.1f s: ticks %llu, frames %llu, stalls %llu, rollbacks %llu (max depth %u), "
                "time-sync waits %llu, bytes sent %llu/s\n", frames, static_cast<double>(cluster.now()) / 1e6,
                static_cast<unsigned long long>(st.ticks), static_cast<unsigned long long>(st.frames_advanced),
                static_cast<unsigned long long>(st.stall_ticks), static_cast<unsigned long long>(st.rollbacks),
                st.max_rollback_depth, static_cast<unsigned long long>(st.time_sync_waits),
                static_cast<unsigned long long>(st.bytes_sent * 60 / st.ticks));
}

// Payload bytes per second at the paper's conditions (2 players, 57 ms one way, jitter 0..20 ms).
TEST(Soak, PaperConditionsBandwidth) {
    for (std::uint32_t loss : {0u, 200000u}) {
        for (int interval : {1, 2, 4}) {
            const auto scene = make_scene(2, 50);
            SessionConfig cfg;
            cfg.checksum_interval = interval;
            cfg.input_delay = 2;
            NetParams net;
            net.latency_us = 47000;
            net.jitter_us = 20000;
            net.loss_ppm = loss;
            Cluster cluster(scene, cfg, net, 7);
            cluster.run_frames(3600);
            const auto& st = cluster.clients[0]->session->stats();
            const double seconds = static_cast<double>(cluster.now()) / 1e6;
            std::printf("loss %u%% K=%d: sent %.0f B/s, received %.0f B/s, %.1f bytes/packet\n", loss / 10000, interval,
                        static_cast<double>(st.bytes_sent) / seconds, static_cast<double>(st.bytes_received) / seconds,
                        static_cast<double>(st.bytes_sent) / static_cast<double>(st.packets_sent));
            cluster.settle(3500);
            expect_all_agree(cluster, 3500);
        }
    }
}

}  // namespace
}  // namespace lockroll::rollback
