// Session behaviour end to end: N in-process sessions over a lossy test network, checked against
// an offline World fed the confirmed inputs.
#include <gtest/gtest.h>

#include <algorithm>

#include "rollback/session.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;
using testing::NetParams;

// Every client confirmed the same inputs and checksums, and an offline World fed those inputs
// reproduces every checksum (the reference).
void expect_converged(Cluster& cluster, const sim::SceneDesc& scene, std::uint32_t frames) {
    const Replay& first = cluster.clients[0]->recorder.replay();
    ASSERT_GE(first.frames(), frames);
    const std::size_t frame_bytes = std::size_t{first.players} * first.input_size;
    for (const auto& c : cluster.clients) {
        const Replay& r = c->recorder.replay();
        ASSERT_GE(r.frames(), frames);
        for (std::uint32_t f = 0; f < frames; ++f) {
            ASSERT_EQ(r.checksums[f], first.checksums[f]) << "confirmed frame " << f + 1 << " differs";
            ASSERT_TRUE(std::equal(r.inputs.begin() + static_cast<std::ptrdiff_t>(f * frame_bytes),
                                   r.inputs.begin() + static_cast<std::ptrdiff_t>((f + 1) * frame_bytes),
                                   first.inputs.begin() + static_cast<std::ptrdiff_t>(f * frame_bytes)));
        }
        EXPECT_TRUE(c->desyncs.empty());
        EXPECT_EQ(c->session->stats().desyncs, 0u);
        for (const auto& ps : c->session->stats().peers) EXPECT_EQ(ps.checksum_mismatches, 0u);
        EXPECT_EQ(c->forward_order_errors, 0u);
    }
    WorldSimulation reference(scene, static_cast<int>(first.players));
    const auto mismatch = verify_replay(first, reference);
    EXPECT_FALSE(mismatch.has_value()) << "offline run differs at frame " << mismatch->frame;
}

// The common run: every client plays `frames` frames, then the cluster runs on until all of them
// confirmed frame `frames`, and they must have converged on the offline reference.
void play_and_converge(Cluster& cluster, const sim::SceneDesc& scene, std::uint32_t frames) {
    cluster.run_frames(frames);
    cluster.settle(frames);
    expect_converged(cluster, scene, frames);
}

SessionConfig base_config(int players, int window, int delay) {
    SessionConfig c;
    c.players = players;
    c.prediction_window = window;
    c.input_delay = delay;
    return c;
}

TEST(Session, RollbackMatchesOfflineReference) {
    const auto scene = make_scene(2, 30);
    Cluster cluster(scene, base_config(2, 8, 1), NetParams{.latency_us = 60000, .jitter_us = 20000, .loss_ppm = 50000}, 1);
    play_and_converge(cluster, scene, 400);
    // The run must actually have exercised rollback for this to mean anything.
    for (const auto& c : cluster.clients) {
        EXPECT_GT(c->session->stats().rollbacks, 0u);
        EXPECT_GT(c->resimulated, 0u);
        EXPECT_GT(c->predicted_frames, 0u);
        EXPECT_LE(c->session->stats().max_rollback_depth, 8u);
        const auto& h = c->session->stats().rollback_depth_histogram;
        std::uint64_t sum = 0;
        for (auto v : h) sum += v;
        EXPECT_EQ(sum, c->session->stats().rollbacks);
    }
}

TEST(Session, WindowFullStallsInsteadOfAdvancing) {
    const auto scene = make_scene(2, 4);
    SessionConfig cfg = base_config(2, 5, 2);
    WorldSimulation sim(scene, 2);
    Session s(cfg, sim);
    const std::array<std::uint8_t, 3> in{1, 2, 3};
    // Nothing ever arrives from player 1: 5 frames may rest on guesses, then it must wait.
    std::uint64_t now = 0;
    for (int t = 0; t < 5; ++t) {
        const auto r = s.advance(in, now += 16667);
        EXPECT_TRUE(r.advanced) << "tick " << t;
    }
    for (int t = 0; t < 10; ++t) {
        const auto r = s.advance(in, now += 16667);
        EXPECT_FALSE(r.advanced);
        EXPECT_EQ(r.frame, 5u);
        EXPECT_EQ(r.blocking_player, 1);
    }
    EXPECT_EQ(s.stats().stall_ticks, 10u);
    EXPECT_EQ(s.stats().frames_advanced, 5u);
    EXPECT_TRUE(s.stalled());

    // Player 1's inputs for frames 0..2 arrive: the window slides by 3 frames.
    WorldSimulation sim1(scene, 2);
    SessionConfig c1 = cfg;
    c1.local_player = 1;
    Session s1(c1, sim1);
    s1.advance(in, 0);  // frames 0..2 of player 1 exist now (delay 2)
    std::vector<Datagram> out;
    s1.poll(0, out);
    ASSERT_EQ(out.size(), 1u);
    s.receive(1, out[0].bytes, now);
    int advanced = 0;
    for (int t = 0; t < 10; ++t) advanced += s.advance(in, now += 16667).advanced ? 1 : 0;
    EXPECT_EQ(advanced, 3);
    EXPECT_EQ(s.frame(), 8u);
    EXPECT_GT(s.stats().stall_time_us, 0u);
}

TEST(Session, LockstepNeverPredictsNorRollsBack) {
    const auto scene = make_scene(2, 30);
    // 40 ms is 2.4 frames one way: delay 4 covers it, pipelined lockstep at the full tick rate
    // after start-up.
    Cluster cluster(scene, base_config(2, 0, 4), NetParams{.latency_us = 40000}, 2);
    play_and_converge(cluster, scene, 300);
    for (const auto& c : cluster.clients) {
        EXPECT_EQ(c->predicted_frames, 0u);
        EXPECT_EQ(c->resimulated, 0u);
        EXPECT_EQ(c->session->stats().rollbacks, 0u);
        EXPECT_EQ(c->session->stats().predicted_inputs, 0u);
        // Only start-up waits (the first inputs need one trip); then every tick advances.
        EXPECT_LE(c->session->stats().stall_ticks, 4u);
        // Every simulated frame is confirmed at once.
        EXPECT_GE(c->session->confirmed_frame() + 0, c->session->frame() - 0);
    }
}

TEST(Session, LockstepWithShortDelayStallsButStaysExact) {
    const auto scene = make_scene(2, 10);
    Cluster cluster(scene, base_config(2, 0, 1), NetParams{.latency_us = 50000, .loss_ppm = 100000}, 3);
    play_and_converge(cluster, scene, 120);
    for (const auto& c : cluster.clients) {
        EXPECT_GT(c->session->stats().stall_ticks, 0u);
        EXPECT_EQ(c->predicted_frames, 0u);
        EXPECT_EQ(c->session->stats().rollbacks, 0u);
    }
}

// One client switches to lockstep mid-game (its own choice: the other stays rollback) and back.
TEST(Session, PredictionWindowSwitchesToLockstepAndBackMidGame) {
    const auto scene = make_scene(2, 20);
    Cluster cluster(scene, base_config(2, 8, 2), NetParams{.latency_us = 40000}, 5);
    cluster.run_frames(120);
    testing::Client& c = *cluster.clients[0];
    EXPECT_GT(c.predicted_frames, 0u);  // rollback: guesses
    EXPECT_THROW(c.session->set_prediction_window(9), std::invalid_argument);  // beyond what it was built with
    c.session->set_prediction_window(0);
    EXPECT_EQ(c.session->prediction_window(), 0);
    cluster.run_frames(60);  // the frames already on guesses get confirmed (some may roll back)
    const std::uint64_t predicted = c.predicted_frames, resimulated = c.resimulated;
    cluster.run_frames(180);
    EXPECT_EQ(c.predicted_frames, predicted);  // lockstep: no new frame runs on a guess
    EXPECT_EQ(c.resimulated, resimulated);
    EXPECT_GE(c.session->confirmed_frame(), c.session->frame() - 0);
    c.session->set_prediction_window(8);  // rollback again (guessing only when it runs ahead)
    EXPECT_EQ(c.session->prediction_window(), 8);
    cluster.run_frames(120);
    cluster.settle(480);
    expect_converged(cluster, scene, 480);
}

TEST(Session, InputDelayChangesMidGame) {
    const auto scene = make_scene(2, 20);
    Cluster cluster(scene, base_config(2, 8, 2), NetParams{.latency_us = 30000, .jitter_us = 10000}, 4);
    cluster.before_tick = [](PlayerId id, testing::Client& c) {
        if (id != 0) return;
        const auto f = c.session->frame();
        if (f == 100) c.session->set_input_delay(6);
        if (f == 200) c.session->set_input_delay(1);
    };
    play_and_converge(cluster, scene, 320);
    const auto& c0 = *cluster.clients[0];
    EXPECT_EQ(c0.session->input_delay(), 1);
    // 6 -> 1 drops five local inputs while the delay catches up; 2 -> 6 drops none.
    EXPECT_EQ(c0.session->stats().dropped_local_inputs, 5u);
    // Growing the delay repeats the previous input into the gap: frames 102..105 of player 0
    // repeat the input of frame 101.
    const Replay& r = c0.recorder.replay();
    for (std::uint32_t f = 102; f <= 105; ++f) {
        const auto a = r.inputs_of(f);
        const auto b = r.inputs_of(101);
        EXPECT_TRUE(std::equal(a.begin(), a.begin() + 3, b.begin())) << "input frame " << f;
    }
}

TEST(Session, FourPlayersLossyConverge) {
    const auto scene = make_scene(4, 20);
    const NetParams net{
        .latency_us = 50000, .jitter_us = 30000, .loss_ppm = 100000, .duplicate_ppm = 50000, .reorder_ppm = 100000};
    Cluster cluster(scene, base_config(4, 8, 2), net, 5);
    play_and_converge(cluster, scene, 300);
    for (const auto& c : cluster.clients) EXPECT_GT(c->session->stats().rollbacks, 0u);
}

// Three players; player 0 sees the late inputs of players 1 and 2 arrive together, with the
// later-arriving one contradicting an *earlier* frame. A session that kept the last (or the
// first) misprediction instead of the earliest would skip part of the needed rollback and
// desync; here the rollback must go back to the earliest wrong frame.
class LateInputs : public ::testing::TestWithParam<bool> {};

TEST_P(LateInputs, EarliestMispredictionWinsWhateverTheArrivalOrder) {
    const bool early_one_last = GetParam();
    const auto scene = make_scene(3, 12);
    SessionConfig cfg = base_config(3, 8, 0);
    std::vector<std::unique_ptr<WorldSimulation>> sims;
    std::vector<std::unique_ptr<Session>> sessions;
    for (int p = 0; p < 3; ++p) {
        SessionConfig c = cfg;
        c.local_player = static_cast<PlayerId>(p);
        sims.push_back(std::make_unique<WorldSimulation>(scene, 3));
        sessions.push_back(std::make_unique<Session>(c, *sims.back()));
    }
    // Player 1 changes its input at frame 5, player 2 at frame 2; neither reaches player 0
    // until frame 7 is shown.
    auto input_of = [](int player, std::uint32_t frame) -> std::array<std::uint8_t, 3> {
        const std::uint32_t change = player == 1 ? 5 : player == 2 ? 2 : 1000;
        const auto v = static_cast<std::uint8_t>(frame >= change ? 100 + player : 10);
        return {v, v, 0};
    };
    std::vector<std::vector<std::uint8_t>> to0;  // datagrams for player 0, in sender order
    std::uint64_t now = 0;
    for (std::uint32_t f = 0; f < 7; ++f) {
        now += 16667;
        std::vector<Datagram> out;
        for (int p = 0; p < 3; ++p) {
            sessions[static_cast<std::size_t>(p)]->advance(input_of(p, f), now);
            out.clear();
            sessions[static_cast<std::size_t>(p)]->poll(now, out);
            for (auto& d : out) {
                if (p == 0) {
                    sessions[d.peer]->receive(0, d.bytes, now);
                } else if (d.peer == 0) {
                    // Hold player 1's and 2's messages to 0, except the very first ones so that
                    // player 0 confirms (and predicts from) their initial input.
                    if (f == 0) sessions[0]->receive(static_cast<PlayerId>(p), d.bytes, now);
                    else if (f == 6) to0.push_back(std::move(d.bytes));
                } else {
                    sessions[d.peer]->receive(static_cast<PlayerId>(p), d.bytes, now);
                }
            }
        }
    }
    ASSERT_EQ(sessions[0]->frame(), 7u);
    ASSERT_EQ(to0.size(), 2u);  // last message of player 1 and of player 2 (redundant: all inputs)
    // to0[0] is from player 1 (wrong from frame 5), to0[1] from player 2 (wrong from frame 2).
    if (early_one_last) {
        sessions[0]->receive(1, to0[0], now);
        sessions[0]->receive(2, to0[1], now);
    } else {
        sessions[0]->receive(2, to0[1], now);
        sessions[0]->receive(1, to0[0], now);
    }
    const auto r = sessions[0]->advance(input_of(0, 7), now + 16667);
    EXPECT_EQ(r.rollback_depth, 5u);  // from frame 2 back up to the displayed frame 7
    // Mispredictions count wrong player-frames: frame 0 (guessed neutral before the first input
    // arrived), then player 1's frames 5..6 and player 2's frames 2..6.
    EXPECT_EQ(sessions[0]->stats().peers[1].mispredictions, 3u);
    EXPECT_EQ(sessions[0]->stats().peers[2].mispredictions, 6u);

    // Frame 7 (now confirmed on player 0) equals an offline run with the true inputs.
    ASSERT_GE(sessions[0]->confirmed_frame(), 7u);
    WorldSimulation ref(scene, 3);
    std::vector<std::uint8_t> frame_inputs(9);
    for (std::uint32_t f = 0; f < 7; ++f) {
        for (int p = 0; p < 3; ++p) {
            const auto in = input_of(p, f);
            std::copy(in.begin(), in.end(), frame_inputs.begin() + 3 * p);
        }
        ref.step(frame_inputs);
    }
    std::vector<std::uint8_t> st(ref.state_size());
    ref.save(st);
    EXPECT_EQ(*sessions[0]->confirmed_checksum(7), ref.checksum(st));
}

INSTANTIATE_TEST_SUITE_P(ArrivalOrder, LateInputs, ::testing::Bool());

TEST(Session, TimeSyncKeepsClientsWithinAFewFrames) {
    const auto scene = make_scene(2, 10);
    Cluster cluster(scene, base_config(2, 8, 2), NetParams{.latency_us = 40000}, 6);
    // Client 1 starts 12 frames late: client 0 races ahead, fills its window and is told to wait.
    cluster.clients[1]->start_offset_us = 200000;
    cluster.run_frames(400);
    const auto& s0 = cluster.clients[0]->session;
    const auto& s1 = cluster.clients[1]->session;
    EXPECT_GT(s0->stats().time_sync_waits, 0u);
    const auto gap = static_cast<std::int64_t>(s0->frame()) - static_cast<std::int64_t>(s1->frame());
    EXPECT_LE(std::abs(gap), 3) << "frames " << s0->frame() << " vs " << s1->frame();
    EXPECT_LE(std::abs(s0->frames_ahead_x100()), 300);
    // With time sync the late start costs a few waits, not a stall every window.
    cluster.settle(400);
    expect_converged(cluster, scene, 400);
}

TEST(Session, TelemetryCountsBytesAndRtt) {
    const auto scene = make_scene(2, 10);
    Cluster cluster(scene, base_config(2, 8, 2), NetParams{.latency_us = 50000}, 7);
    cluster.run_frames(240);
    for (const auto& c : cluster.clients) {
        const auto& st = c->session->stats();
        EXPECT_GT(st.bytes_sent, 0u);
        EXPECT_GT(st.bytes_received, 0u);
        const PlayerId other = c->session->config().local_player == 0 ? 1 : 0;
        // RTT ~ 100 ms plus up to a tick of waiting for the peer's next send.
        EXPECT_GE(st.peers[other].rtt_us, 95000u);
        EXPECT_LE(st.peers[other].rtt_us, 100000u + 2 * 16667u);
        // Steady state at 0 % loss: a few inputs, an ack and a checksum per message, 60 per second.
        EXPECT_LT(st.bytes_sent / st.packets_sent, 40u);
    }
}

TEST(Session, RejectsBadConfigAndFaults) {
    const auto scene = make_scene(2, 4);
    WorldSimulation sim(scene, 2);
    SessionConfig cfg;
    cfg.players = 0;
    EXPECT_THROW(Session(cfg, sim), std::invalid_argument);
    cfg = {};
    cfg.local_player = 2;
    EXPECT_THROW(Session(cfg, sim), std::invalid_argument);
    cfg = {};
    cfg.input_capacity = 100;
    EXPECT_THROW(Session(cfg, sim), std::invalid_argument);
    cfg = {};
    Session s(cfg, sim);
    EXPECT_FALSE(s.inject_fault(10, 0, 0, 3).empty());   // body 0 is a static wall
    EXPECT_FALSE(s.inject_fault(10, 6, 9, 3).empty());   // no field 9
    EXPECT_TRUE(s.inject_fault(10, 6, 0, 3).empty());    // a player box
    EXPECT_THROW(s.set_input_delay(-1), std::invalid_argument);
}

}  // namespace
}  // namespace lockroll::rollback
