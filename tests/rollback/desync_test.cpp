// Desync alerts: only confirmed frames are compared, a flipped bit on one client is caught within
// one checksum interval and narrowed to the body and field that was flipped.
#include <gtest/gtest.h>

#include "rollback/session.h"
#include "rollback/session_impl.h"
#include "sim/snapshot.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;
using testing::NetParams;

struct Case {
    std::uint32_t loss_ppm;
    int players;
    int interval;
    std::uint32_t frame;
    std::uint32_t body;
    int field;
    int bit;
    bool rigid = false;  // rigid scene: 13 fields per body, orientation and angular velocity too
};

class DesyncInjection : public ::testing::TestWithParam<Case> {};

TEST_P(DesyncInjection, AlertFiresWithinOneIntervalAndNamesBodyAndField) {
    const Case c = GetParam();
    auto scene = make_scene(c.players, 30);
    scene.rigid.enabled = c.rigid;
    SessionConfig cfg;
    cfg.players = c.players;
    cfg.input_delay = 2;
    cfg.checksum_interval = c.interval;
    NetParams net;
    net.latency_us = 40000;
    net.jitter_us = 20000;
    net.loss_ppm = c.loss_ppm;
    Cluster cluster(scene, cfg, net, 11);
    const PlayerId bad = 1;
    ASSERT_EQ(cluster.clients[bad]->session->inject_fault(c.frame, c.body, c.field, c.bit), "");
    const std::uint32_t due = (c.frame + c.interval - 1) / c.interval * c.interval;  // next checkpoint
    cluster.run_frames(c.frame + 120);
    cluster.settle(c.frame + 100);

    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        const auto& cl = *cluster.clients[i];
        // Every client compares with every peer; the faulty one disagrees with all of them, the
        // others only with the faulty one.
        const std::size_t expected_events = i == bad ? static_cast<std::size_t>(c.players - 1) : 1;
        ASSERT_EQ(cl.desyncs.size(), expected_events) << "client " << i;
        for (const DesyncEvent& e : cl.desyncs) {
            if (i != bad) {
                EXPECT_EQ(e.peer, bad);
            }
            // Without loss the alert fires at the first checkpoint after the fault; a lost
            // announcement delays it to a later checkpoint, narrowing still finds the frame.
            if (c.loss_ppm == 0) {
                EXPECT_EQ(e.frame, due) << "alert must fire at the first checkpoint";
            }
            EXPECT_GE(e.frame, due);
            EXPECT_LE(e.frame, due + 3 * static_cast<std::uint32_t>(c.interval));
            EXPECT_NE(e.local_checksum, e.remote_checksum);
        }
        ASSERT_EQ(cl.reports.size(), expected_events) << "client " << i;
        for (const DesyncReport& r : cl.reports) {
            EXPECT_EQ(r.outcome, NarrowOutcome::BodyNamed) << r.summary;
            EXPECT_GE(r.detected_frame, due);
            EXPECT_EQ(r.frame, c.frame) << r.summary;
            EXPECT_EQ(r.body_id, c.body) << r.summary;
            EXPECT_EQ(r.field, c.field) << r.summary;
            EXPECT_EQ(r.field_name, sim::kBodyFieldNames[c.field]);
            // Orientation is stored in units of 2^-30 and reported as Q32.32 raw (x 4).
            const int shift = c.field >= 6 && c.field < 10 ? 2 : 0;
            EXPECT_EQ(static_cast<std::uint64_t>(r.local_value ^ r.remote_value), std::uint64_t{1} << (c.bit + shift));
            // Evidence: this client's state at that frame, renderable for a person to diff.
            ASSERT_EQ(r.local_state.size(), cl.sim.state_size());
            const std::string text = cl.sim.describe_state(r.local_state);
            EXPECT_NE(text.find("position.x"), std::string::npos);
            EXPECT_NE(r.summary.find(sim::kBodyFieldNames[c.field]), std::string::npos);
        }
        const auto& st = cl.session->stats();
        EXPECT_GE(st.desyncs, 1u);
    }
}

INSTANTIATE_TEST_SUITE_P(Faults, DesyncInjection,
                         ::testing::Values(Case{0, 2, 1, 50, 20, 0, 30},    // a ball's position.x, K = 1
                                           Case{0, 2, 1, 80, 7, 4, 24},     // player 1's velocity.y
                                           Case{0, 2, 10, 53, 15, 2, 28},   // K = 10: alert at 60, narrowed to 53
                                           Case{0, 3, 4, 41, 30, 5, 20},    // three players
                                           Case{100000, 2, 1, 70, 12, 1, 26},   // 10 % loss
                                           Case{100000, 4, 5, 64, 25, 3, 22},   // 4 players, 10 % loss
                                           Case{0, 2, 1, 45, 20, 11, 20, true},  // rigid: angular_velocity.y
                                           Case{0, 2, 4, 57, 9, 7, 12, true}));  // rigid: orientation.x

TEST(Desync, LossyRunsNeverRaiseFalseAlarms) {
    // Heavy misprediction (predicted frames differ all the time) but confirmed frames agree.
    const auto scene = make_scene(3, 20);
    SessionConfig cfg;
    cfg.players = 3;
    cfg.input_delay = 0;
    NetParams net;
    net.latency_us = 80000;
    net.jitter_us = 40000;
    net.loss_ppm = 200000;
    net.reorder_ppm = 100000;
    Cluster cluster(scene, cfg, net, 12);
    cluster.run_frames(300);
    cluster.settle(290);
    for (const auto& cl : cluster.clients) {
        EXPECT_TRUE(cl->desyncs.empty());
        EXPECT_GT(cl->session->stats().rollbacks, 10u);
        std::uint64_t matches = 0;
        for (const auto& p : cl->session->stats().peers) {
            EXPECT_EQ(p.checksum_mismatches, 0u);
            matches += p.checksum_matches;
        }
        EXPECT_GT(matches, 200u);
    }
}

TEST(Desync, NarrowingGivesUpWhenThePeerIsSilent) {
    const auto scene = make_scene(2, 10);
    SessionConfig cfg;
    cfg.query_resend_us = 20000;
    NetParams net;
    net.latency_us = 20000;
    Cluster cluster(scene, cfg, net, 13);
    ASSERT_EQ(cluster.clients[1]->session->inject_fault(30, 10, 1, 33), "");
    // After the alert, drop every query and reply so narrowing cannot finish.
    cluster.filter = [](PlayerId, PlayerId, const std::vector<std::uint8_t>& b) {
        const auto k = peek_kind(b);
        return k == MessageKind::Input;
    };
    cluster.run_frames(30 + 60 * 5);
    for (const auto& cl : cluster.clients) {
        ASSERT_EQ(cl->desyncs.size(), 1u);
        ASSERT_EQ(cl->reports.size(), 1u);
        EXPECT_EQ(cl->reports[0].outcome, NarrowOutcome::NoReply);
        EXPECT_EQ(cl->reports[0].frame, 30u);
    }
}

}  // namespace
}  // namespace lockroll::rollback
