// rollback::Session, the installed facade: every call reaches the one SessionImpl it owns, so a
// game's view (the facade's answers) and the state machine's own agree, call by call, on a
// match played over the lossy in-test network; and the commands given to the facade change the
// state machine.
#include <gtest/gtest.h>

#include "rollback/session.h"
#include "rollback/session_impl.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;

SessionConfig handshaking(int players) {
    SessionConfig c;
    c.players = players;
    c.handshake = true;
    c.match_id = 0xFACADE;
    return c;
}

TEST(SessionFacade, AnswersWhatItsStateMachineAnswers) {
    const auto scene = make_scene(3, 12);
    Cluster cluster(scene, handshaking(3), {30000, 4000, 50000}, 5);
    cluster.run_frames(240);
    cluster.settle(240);
    for (const auto& c : cluster.clients) {
        const Session& s = *c->session;
        const SessionImpl& impl = s.impl();
        ASSERT_EQ(s.phase(), SessionPhase::Running);
        EXPECT_EQ(s.phase(), impl.phase());
        EXPECT_EQ(s.frame(), impl.frame());
        EXPECT_GE(s.frame(), 240u);
        EXPECT_EQ(s.confirmed_frame(), impl.confirmed_frame());
        EXPECT_EQ(s.input_delay(), impl.input_delay());
        EXPECT_EQ(s.prediction_window(), impl.prediction_window());
        EXPECT_EQ(s.stalled(), impl.stalled());
        EXPECT_EQ(&s.stats(), &impl.stats());  // the same counters, not a copy
        EXPECT_EQ(&s.config(), &impl.config());
        EXPECT_EQ(s.local_slots().data(), impl.local_slots().data());
        EXPECT_EQ(s.confirmed_checksum(240), impl.confirmed_checksum(240));
        ASSERT_TRUE(s.confirmed_checksum(240).has_value());
        EXPECT_EQ(s.saved_state(s.frame())->data(), impl.saved_state(impl.frame())->data());
        for (PlayerId p = 0; p < 3; ++p) {
            EXPECT_EQ(s.slot_state(p), impl.membership().state(p));
            if (p == s.config().local_player) continue;
            EXPECT_EQ(s.rtt_us(p), impl.rtt_us(p));
            EXPECT_GT(s.rtt_us(p), 0u);
            EXPECT_EQ(s.peer_ack(p), impl.peer_ack(p));
            EXPECT_EQ(s.network_stats(p, cluster.now()).ping_us, impl.network_stats(p, cluster.now()).ping_us);
        }
    }
    // Every client agrees on the confirmed frame's checksum, read through the facade.
    EXPECT_EQ(cluster.clients[0]->session->confirmed_checksum(240), cluster.clients[1]->session->confirmed_checksum(240));
    EXPECT_EQ(cluster.clients[0]->session->confirmed_checksum(240), cluster.clients[2]->session->confirmed_checksum(240));
}

TEST(SessionFacade, CommandsAndEventsGoThroughToTheStateMachine) {
    const auto scene = make_scene(2, 4);
    SessionConfig cfg;
    cfg.players = 2;
    WorldSimulation sim(scene, 2);
    Session s(cfg, sim);
    s.set_input_delay(5);
    EXPECT_EQ(s.impl().input_delay(), 5);
    s.set_prediction_window(0);
    EXPECT_EQ(s.impl().prediction_window(), 0);
    EXPECT_THROW(s.set_prediction_window(cfg.prediction_window + 1), std::invalid_argument);
    s.disconnect_player(1, 1000);
    // The facade drains the one queue: after it, the state machine has nothing left either.
    SessionEvent e;
    int drained = 0;
    bool kick_told = false;
    while (s.next_event(e)) {
        ++drained;
        // Told as a kick the two-player rule settled (one vote of two), not as a silence.
        kick_told = kick_told || (e.kind == SessionEvent::Kind::Disconnected && e.peer == 1 &&
                                  e.reason == SessionEvent::Reason::KickVoteTwoPlayerRule);
    }
    EXPECT_GT(drained, 0);  // the kick was told
    EXPECT_TRUE(kick_told);
    EXPECT_FALSE(s.impl().next_event(e));
    EXPECT_EQ(s.inject_fault(0, 0, 0, 0), s.impl().inject_fault(0, 0, 0, 0));
}

}  // namespace
}  // namespace lockroll::rollback
