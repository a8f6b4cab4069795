// Session::set_last_frame: a run of N frames ends on frame N. Held there, a session still takes
// the late inputs, rolls back and confirms (so every peer confirms N with the same checksum), and
// a held tick is not a stall. Virtual time, 3 players with latency, loss and jitter.
#include <gtest/gtest.h>

#include "test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::NetParams;

TEST(LastFrame, HeldSessionsConfirmTheLastFrameAndStepNoFurther) {
    constexpr std::uint32_t kLast = 240;
    SessionConfig c;  // window 8, 3-byte inputs
    c.players = 3;
    Cluster cluster(testing::make_scene(3, 10), c, NetParams{.latency_us = 40000, .jitter_us = 10000, .loss_ppm = 50000}, 11);
    for (auto& client : cluster.clients) client->session->set_last_frame(kLast);
    cluster.run_frames(kLast);
    const std::uint64_t stalls_at_last = cluster.clients[0]->session->stats().stall_ticks;
    cluster.settle(kLast);
    // Two more seconds of ticks (as a runner lingers): nobody steps on, nobody stalls.
    const std::uint64_t until = cluster.now() + 2'000'000;
    cluster.run([until](const Cluster& k) { return k.now() >= until; }, 3'000'000);
    for (const auto& client : cluster.clients) {
        EXPECT_EQ(client->session->frame(), kLast);
        EXPECT_EQ(client->session->confirmed_frame(), kLast);
        ASSERT_TRUE(client->confirmed.count(kLast));
        EXPECT_EQ(client->confirmed.at(kLast), cluster.clients[0]->confirmed.at(kLast));
    }
    // Loss made some late inputs contradict guesses near the end: the held frames rolled back.
    EXPECT_GT(cluster.clients[0]->resimulated + cluster.clients[1]->resimulated + cluster.clients[2]->resimulated, 0u);
    EXPECT_LE(cluster.clients[0]->session->stats().stall_ticks - stalls_at_last, 2u);
}

}  // namespace
}  // namespace lockroll::rollback
