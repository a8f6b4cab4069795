// Sync on its own (rollback/sync.h): the frame loop and the rollback decision, driven by hand
// without a session or a network. The game is the test scene of test_support.h (player boxes
// moved by 3-byte inputs); every comparison is with a straight-line run of the same inputs.
// (sync_test_test.cpp is the SyncTest feature's; this file is the Sync class's.)
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "rollback/sync.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::make_scene;
using Bytes = std::vector<std::uint8_t>;

const Bytes kNeutral{0, 0, 0};
const Bytes kForward{100, 0, 0};  // pushes a player box: a state any misprediction changes
const Bytes kRight{0, 156, 0};    // -100 on the right axis

std::uint64_t live_checksum(const Simulation& sim) {
    std::vector<std::uint8_t> buf(sim.state_size());
    return sim.checksum(sim.save_to(buf));
}

// Every player's input of every frame, decided up front (a WalkBot per player).
struct Script {
    Script(int players, std::uint32_t frames, std::uint64_t seed) : inputs(static_cast<std::size_t>(players)) {
        for (int p = 0; p < players; ++p) {
            testing::WalkBot bot(seed * 31 + static_cast<std::uint64_t>(p));
            for (std::uint32_t f = 0; f < frames; ++f) {
                const auto a = bot.next();
                inputs[static_cast<std::size_t>(p)].emplace_back(a.begin(), a.end());
            }
        }
    }
    const Bytes& at(PlayerId p, std::uint32_t frame) const { return inputs[p][frame]; }
    std::vector<std::vector<Bytes>> inputs;  // [player][frame]
};

// Checksums of frames 0..frames of a straight-line run (no prediction, no save/load).
std::vector<std::uint64_t> straight_line(const Script& s, int players, std::uint32_t frames) {
    WorldSimulation sim(make_scene(players, 2), players);
    std::vector<std::uint64_t> sums{live_checksum(sim)};
    Bytes all;
    for (std::uint32_t f = 0; f < frames; ++f) {
        all.clear();
        for (int p = 0; p < players; ++p) {
            const Bytes& in = s.at(static_cast<PlayerId>(p), f);
            all.insert(all.end(), in.begin(), in.end());
        }
        sim.step(all);
        sums.push_back(live_checksum(sim));
    }
    return sums;
}

struct Simulated {
    std::uint32_t frame;
    bool resimulation;
    std::uint64_t predicted_mask;
    Bytes inputs;
};

struct Recorder : SessionObserver {
    void on_frame_simulated(const FrameSimulated& f) override {
        simulated.push_back({f.frame, f.resimulation, f.predicted_mask, Bytes(f.inputs.begin(), f.inputs.end())});
    }
    void on_rollback_end(const RollbackInfo& r) override { rollbacks.push_back(r); }
    std::vector<Simulated> simulated;
    std::vector<RollbackInfo> rollbacks;
};

SyncConfig config(int players, int window, int evidence = 16) {
    SyncConfig c;
    c.players = players;
    c.local_player = 0;
    c.input_size = kWorldInputSize;
    c.prediction_window = window;
    c.evidence_frames = evidence;
    c.input_capacity = 64;
    return c;
}

// A Sync over the test scene, with the session's tick written out: rollback first, the local
// input, then a step unless the window is full, then every confirmable frame confirmed.
struct Rig {
    explicit Rig(const SyncConfig& c)
        : sim(make_scene(c.players, 2), c.players), sync(c, sim, predictor, &recorder, stats, [] { return 0ull; }) {}

    // One tick with the local input `local`; true if it stepped.
    bool tick(const Bytes& local, int delay = 0) {
        sync.rollback_if_needed();
        confirm_all();
        if (!sync.local_queue_full(delay)) sync.add_local_input(local, delay);
        if (sync.must_wait(delay)) return false;
        sync.step_forward();
        confirm_all();
        return true;
    }
    void confirm_all() {
        while (!sync.rollback_pending() && sync.confirmed_frame() < sync.confirmable_frame()) {
            const FrameConfirmed c = sync.confirm_next();
            confirmed.push_back({c.frame, Bytes(c.inputs.begin(), c.inputs.end()), c.checksum});
        }
    }
    struct Confirmed {
        std::uint32_t frame;
        Bytes inputs;
        std::uint64_t checksum;
    };

    WorldSimulation sim;
    RepeatLastPredictor predictor;
    Recorder recorder;
    SessionStats stats;
    Sync sync;
    std::vector<Confirmed> confirmed;
};

TEST(SyncCore, ConstructionChecksItsConfig) {
    WorldSimulation sim(make_scene(2, 0), 2);
    RepeatLastPredictor predictor;
    SessionStats stats;
    const auto make = [&](SyncConfig c) { Sync s(c, sim, predictor, nullptr, stats, [] { return 0ull; }); };
    SyncConfig c = config(2, 8);
    EXPECT_NO_THROW(make(c));
    c.players = 0;
    EXPECT_THROW(make(c), std::invalid_argument);
    c.players = kMaxPlayers + 1;
    EXPECT_THROW(make(c), std::invalid_argument);
    c = config(2, 8);
    c.local_player = 2;
    EXPECT_THROW(make(c), std::invalid_argument);
    c = config(2, -1);
    EXPECT_THROW(make(c), std::invalid_argument);
    c = config(2, 32);  // capacity 64 must exceed twice the window
    EXPECT_THROW(make(c), std::invalid_argument);
    c = config(2, 31);
    EXPECT_NO_THROW(make(c));
    c = config(2, 8);
    c.retain_frames = 32;  // half the capacity
    EXPECT_THROW(make(c), std::invalid_argument);
}

TEST(SyncCore, StallsWhenThePredictionWindowIsFull) {
    Rig r(config(2, 3));
    EXPECT_EQ(r.sync.ring().slots(), 3u + 1u + 16u);
    for (std::uint32_t f = 0; f < 3; ++f) EXPECT_TRUE(r.tick(kNeutral)) << f;
    EXPECT_EQ(r.sync.frame(), 3u);
    // Three frames rest on player 1's guesses: the fourth may not run.
    EXPECT_TRUE(r.sync.must_wait(0));
    EXPECT_EQ(r.sync.blocking_player(), 1);
    EXPECT_FALSE(r.tick(kNeutral));
    EXPECT_FALSE(r.tick(kNeutral));
    EXPECT_EQ(r.sync.frame(), 3u);
    ASSERT_EQ(r.recorder.simulated.size(), 3u);
    for (const Simulated& s : r.recorder.simulated) {
        EXPECT_FALSE(s.resimulation);
        EXPECT_EQ(s.predicted_mask, 0b10u) << "frame " << s.frame;
    }
    EXPECT_EQ(r.stats.predicted_inputs, 3u);
    // Each confirmed remote frame opens the window by one.
    EXPECT_EQ(r.sync.add_remote_input(1, 0, kNeutral), InputQueue::Add::Stored);
    EXPECT_TRUE(r.tick(kNeutral));
    EXPECT_FALSE(r.tick(kNeutral));
    EXPECT_EQ(r.sync.frame(), 4u);
    for (std::uint32_t f = 1; f < 4; ++f) r.sync.add_remote_input(1, f, kNeutral);
    int steps = 0;
    while (r.tick(kNeutral)) ++steps;
    EXPECT_EQ(steps, 3);
    EXPECT_EQ(r.sync.frame(), 7u);  // confirmed inputs 0..3, plus a window of 3
    EXPECT_EQ(r.stats.rollbacks, 0u);  // every guess (neutral) was right
}

TEST(SyncCore, LocalQueueFullStallsUntilPeersAcknowledge) {
    SyncConfig c = config(1, 2);  // alone: only the local queue can hold the loop
    c.input_capacity = 8;
    Rig r(c);
    for (std::uint32_t f = 0; f < 8; ++f) ASSERT_TRUE(r.tick(kForward)) << f;
    // Inputs 0..7 were never acknowledged (keep_from 0): frame 8's has no room.
    EXPECT_TRUE(r.sync.local_queue_full(0));
    EXPECT_TRUE(r.sync.must_wait(0));
    EXPECT_FALSE(r.tick(kForward));
    EXPECT_EQ(r.sync.confirmed_frame(), 8u);
    r.sync.set_local_resend_floor(5);  // the peer has 0..4
    EXPECT_FALSE(r.sync.local_queue_full(0));
    EXPECT_EQ(r.sync.queue(0).floor(), 5u);
    int steps = 0;
    while (r.tick(kForward)) ++steps;
    EXPECT_EQ(steps, 5);  // frames 8..12 fit from floor 5
    EXPECT_EQ(r.sync.frame(), 13u);
    // A delay reaches further ahead, so the queue fills sooner.
    r.sync.set_local_resend_floor(13);
    EXPECT_FALSE(r.sync.local_queue_full(7));
    EXPECT_TRUE(r.sync.local_queue_full(8));
}

TEST(SyncCore, LockstepNeverPredicts) {
    constexpr std::uint32_t kFrames = 40;
    const Script script(2, kFrames + 1, 3);
    const auto reference = straight_line(script, 2, kFrames);
    Rig r(config(2, 0));
    EXPECT_EQ(r.sync.ring().slots(), 0u + 1u + 16u);
    // The remote input of frame f arrives after a lag of 0..3 ticks.
    std::uint32_t sent = 0;
    for (int t = 0; r.sync.frame() < kFrames; ++t) {
        ASSERT_LT(t, 400);
        if (t % 4 == 3 && sent < kFrames) r.sync.add_remote_input(1, sent, script.at(1, sent)), ++sent;
        if (t % 4 == 1 && sent < kFrames) r.sync.add_remote_input(1, sent, script.at(1, sent)), ++sent;
        const bool blocked = r.sync.frame() >= r.sync.queue(1).confirmed_count();
        EXPECT_EQ(r.sync.must_wait(0), blocked) << "tick " << t;
        EXPECT_EQ(r.tick(script.at(0, r.sync.frame())), !blocked);
        EXPECT_FALSE(r.sync.rollback_pending());
    }
    EXPECT_EQ(r.sync.frame(), kFrames);
    ASSERT_EQ(r.recorder.simulated.size(), kFrames);
    for (const Simulated& s : r.recorder.simulated) {
        EXPECT_EQ(s.predicted_mask, 0u) << "frame " << s.frame;
        EXPECT_FALSE(s.resimulation);
    }
    EXPECT_EQ(r.stats.predicted_inputs, 0u);
    EXPECT_EQ(r.stats.rollbacks, 0u);
    EXPECT_TRUE(r.recorder.rollbacks.empty());
    // Lockstep confirms each frame as soon as it runs.
    ASSERT_EQ(r.confirmed.size(), kFrames);
    for (const auto& c : r.confirmed) EXPECT_EQ(c.checksum, reference[c.frame]) << "frame " << c.frame;
    EXPECT_EQ(live_checksum(r.sim), reference[kFrames]);
}

TEST(SyncCore, ContradictingInputRollsBackToItsFrame) {
    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 6; ++f) ASSERT_TRUE(r.tick(kNeutral));
    const std::uint64_t displayed_before = live_checksum(r.sim);
    // Frames 0 and 1 were guessed right (neutral); frame 2 was not.
    r.sync.add_remote_input(1, 0, kNeutral);
    r.sync.add_remote_input(1, 1, kNeutral);
    EXPECT_FALSE(r.sync.rollback_pending());
    r.sync.add_remote_input(1, 2, kForward);
    EXPECT_TRUE(r.sync.rollback_pending());
    EXPECT_EQ(r.stats.peers[1].mispredictions, 1u);
    EXPECT_THROW(r.sync.step_forward(), std::logic_error);  // nothing runs on a known-wrong state
    EXPECT_THROW(r.sync.confirm_next(), std::logic_error);

    r.recorder.simulated.clear();
    EXPECT_EQ(r.sync.rollback_if_needed(), 4u);
    EXPECT_FALSE(r.sync.rollback_pending());
    EXPECT_EQ(r.sync.frame(), 6u);  // back to the displayed frame
    ASSERT_EQ(r.recorder.rollbacks.size(), 1u);
    const RollbackInfo& info = r.recorder.rollbacks[0];
    EXPECT_EQ(info.from_frame, 2u);
    EXPECT_EQ(info.displayed_frame, 6u);
    EXPECT_EQ(info.depth, 4u);
    EXPECT_EQ(info.displayed_checksum_before, displayed_before);
    EXPECT_EQ(info.displayed_checksum_after, live_checksum(r.sim));
    EXPECT_TRUE(info.displayed_changed());
    // Frames 3..6 were resimulated: the input of frame 2 confirmed, 3..5 guessed as its repeat.
    ASSERT_EQ(r.recorder.simulated.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
        const Simulated& s = r.recorder.simulated[i];
        EXPECT_EQ(s.frame, 3u + i);
        EXPECT_TRUE(s.resimulation);
        EXPECT_EQ(s.predicted_mask, i == 0 ? 0u : 0b10u) << "frame " << s.frame;
        EXPECT_EQ(Bytes(s.inputs.begin() + 3, s.inputs.end()), kForward) << "frame " << s.frame;
    }
    EXPECT_EQ(r.stats.rollbacks, 1u);
    EXPECT_EQ(r.stats.resimulated_frames, 4u);
    EXPECT_EQ(r.stats.max_rollback_depth, 4u);
    ASSERT_EQ(r.stats.rollback_depth_histogram.size(), 9u);
    EXPECT_EQ(r.stats.rollback_depth_histogram[4], 1u);
    // The corrected state is the one a run with those inputs reaches without any rollback.
    Script s(2, 6, 1);
    for (std::uint32_t f = 0; f < 6; ++f) {
        s.inputs[0][f] = kNeutral;
        s.inputs[1][f] = f < 2 ? kNeutral : kForward;
    }
    EXPECT_EQ(live_checksum(r.sim), straight_line(s, 2, 6)[6]);
    // Once done, nothing more is pending: the next tick steps forward only.
    EXPECT_EQ(r.sync.rollback_if_needed(), 0u);
    EXPECT_EQ(r.stats.rollbacks, 1u);
}

TEST(SyncCore, ConfirmingInputDoesNotRollBack) {
    Rig r(config(2, 8));
    // Frame 0's remote input arrives before frame 0 runs: confirmed, nothing to compare.
    EXPECT_EQ(r.sync.add_remote_input(1, 0, kRight), InputQueue::Add::Stored);
    EXPECT_FALSE(r.sync.rollback_pending());
    for (std::uint32_t f = 0; f < 6; ++f) ASSERT_TRUE(r.tick(kNeutral));
    // Frames 1..5 were guessed as repeats of kRight; the same inputs confirm them.
    for (std::uint32_t f = 1; f < 6; ++f) {
        EXPECT_EQ(r.sync.add_remote_input(1, f, kRight), InputQueue::Add::Stored);
        EXPECT_FALSE(r.sync.rollback_pending()) << "frame " << f;
    }
    EXPECT_EQ(r.sync.rollback_if_needed(), 0u);
    EXPECT_EQ(r.stats.rollbacks, 0u);
    EXPECT_EQ(r.stats.peers[1].mispredictions, 0u);
    for (const Simulated& s : r.recorder.simulated) EXPECT_FALSE(s.resimulation);
    // A duplicate, even of a mispredicted frame, is not a second arrival.
    EXPECT_EQ(r.sync.add_remote_input(1, 3, kRight), InputQueue::Add::Duplicate);
    // A conflicting copy is refused and schedules nothing (the confirmed input stands).
    EXPECT_EQ(r.sync.add_remote_input(1, 3, kForward), InputQueue::Add::Conflict);
    EXPECT_FALSE(r.sync.rollback_pending());
    EXPECT_EQ(Bytes(r.sync.queue(1).confirmed(3).begin(), r.sync.queue(1).confirmed(3).end()), kRight);
}

TEST(SyncCore, AbsentFlagAloneIsAMisprediction) {
    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 4; ++f) ASSERT_TRUE(r.tick(kNeutral));
    // The guesses were neutral bytes from a present player; the slot turns out absent.
    EXPECT_EQ(r.sync.add_remote_input(1, 0, kNeutral, true), InputQueue::Add::Stored);
    EXPECT_TRUE(r.sync.rollback_pending());
    EXPECT_EQ(r.sync.rollback_if_needed(), 4u);
    // An absent slot is guessed to stay absent: confirming that needs no rollback.
    for (std::uint32_t f = 1; f < 4; ++f) r.sync.add_remote_input(1, f, kNeutral, true);
    EXPECT_FALSE(r.sync.rollback_pending());
    EXPECT_EQ(r.stats.rollbacks, 1u);
}

// The minimum over every player and arrival is kept: a later arrival for a later frame never
// postpones an earlier needed rollback (the 3+ player bug).
TEST(SyncCore, EarliestMispredictionWinsWhateverTheArrivalOrder) {
    for (const bool early_first : {false, true}) {
        SCOPED_TRACE(early_first ? "player 1 first" : "player 2 first");
        Rig r(config(3, 8));
        for (std::uint32_t f = 0; f < 7; ++f) ASSERT_TRUE(r.tick(kNeutral));
        const auto player1 = [&] {  // wrong from frame 1
            r.sync.add_remote_input(1, 0, kNeutral);
            r.sync.add_remote_input(1, 1, kForward);
            r.sync.add_remote_input(1, 2, kForward);
        };
        const auto player2 = [&] {  // wrong from frame 4
            for (std::uint32_t f = 0; f < 4; ++f) r.sync.add_remote_input(2, f, kNeutral);
            r.sync.add_remote_input(2, 4, kRight);
            r.sync.add_remote_input(2, 5, kForward);  // another misprediction, later still
        };
        if (early_first) player1(), player2();
        else player2(), player1();
        // Every arrival that differs from what its frame used counts (frames 1, 2 and 4, 5).
        EXPECT_EQ(r.stats.peers[1].mispredictions, 2u);
        EXPECT_EQ(r.stats.peers[2].mispredictions, 2u);
        EXPECT_EQ(r.sync.rollback_if_needed(), 6u);  // from frame 1 to the displayed 7
        ASSERT_EQ(r.recorder.rollbacks.size(), 1u);
        EXPECT_EQ(r.recorder.rollbacks[0].from_frame, 1u);
        EXPECT_EQ(r.stats.rollbacks, 1u);
        Script s(3, 7, 1);
        for (std::uint32_t f = 0; f < 7; ++f) {
            s.inputs[0][f] = kNeutral;
            s.inputs[1][f] = f == 0 ? kNeutral : kForward;
            s.inputs[2][f] = f < 4 ? kNeutral : f == 4 ? kRight : kForward;  // 6: a repeat of 5
        }
        EXPECT_EQ(live_checksum(r.sim), straight_line(s, 3, 7)[7]);
    }
}

TEST(SyncCore, ConfirmsFramesInOrderEachOnce) {
    const Script script(2, 12, 5);
    const auto reference = straight_line(script, 2, 11);
    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 5; ++f) ASSERT_TRUE(r.tick(script.at(0, f)));
    EXPECT_EQ(r.sync.confirmable_frame(), 0u);  // no remote input: nothing is final
    EXPECT_THROW(r.sync.confirm_next(), std::logic_error);
    EXPECT_TRUE(r.confirmed.empty());
    // Remote inputs far beyond the displayed frame: confirmable stops at frame() (only
    // simulated frames can be confirmed).
    for (std::uint32_t f = 0; f < 10; ++f) r.sync.add_remote_input(1, f, script.at(1, f));
    EXPECT_EQ(r.sync.inputs_complete(), 5u);  // the local queue has 0..4
    EXPECT_EQ(r.sync.confirmable_frame(), 5u);
    r.sync.rollback_if_needed();
    r.confirm_all();
    ASSERT_EQ(r.confirmed.size(), 5u);
    for (std::uint32_t i = 0; i < 5; ++i) {
        const auto& c = r.confirmed[i];
        EXPECT_EQ(c.frame, i + 1);
        EXPECT_EQ(c.checksum, reference[c.frame]);
        Bytes expected = script.at(0, i);  // the inputs of frame - 1, player by player
        expected.insert(expected.end(), script.at(1, i).begin(), script.at(1, i).end());
        EXPECT_EQ(c.inputs, expected) << "frame " << c.frame;
    }
    EXPECT_EQ(r.sync.confirmed_frame(), 5u);
    EXPECT_THROW(r.sync.confirm_next(), std::logic_error);  // frame 6 is not simulated yet
    for (std::uint32_t f = 5; f < 10; ++f) ASSERT_TRUE(r.tick(script.at(0, f)));
    ASSERT_EQ(r.confirmed.size(), 10u);
    for (std::uint32_t i = 0; i < 10; ++i) EXPECT_EQ(r.confirmed[i].frame, i + 1);
    EXPECT_EQ(r.confirmed.back().checksum, reference[10]);
    // Confirmation moves the floors: inputs before the next frame to confirm are dropped
    // (the local queue keeps what the peer has not acknowledged: keep_from 0 here).
    EXPECT_EQ(r.sync.queue(1).floor(), 10u);
    EXPECT_EQ(r.sync.queue(0).floor(), 0u);
}

// Late remote inputs, many rollbacks: every confirmed frame and the final state equal a run
// that knew all inputs from the start.
TEST(SyncCore, ResimulationMatchesAStraightLineRun) {
    constexpr std::uint32_t kFrames = 180;
    const Script script(2, kFrames + 40, 11);
    const auto reference = straight_line(script, 2, kFrames + 39);
    Rig r(config(2, 8));
    sim::SplitMix64 rng(99);
    std::uint32_t delivered = 0;
    for (int t = 0; r.sync.confirmed_frame() < kFrames; ++t) {
        ASSERT_LT(t, 2000);
        // Bursts: 0..2 remote inputs per tick, so the remote stream lags by a varying amount.
        const auto burst = rng.below(3);
        for (std::uint64_t k = 0; k < burst && delivered < kFrames + 19; ++k, ++delivered)
            ASSERT_EQ(r.sync.add_remote_input(1, delivered, script.at(1, delivered)), InputQueue::Add::Stored);
        r.tick(script.at(0, r.sync.frame()));
        r.sync.set_local_resend_floor(r.sync.frame());  // the peer acknowledges at once
        ASSERT_LE(r.sync.frame(), r.sync.queue(1).confirmed_count() + 8u);  // never beyond the window
    }
    EXPECT_GE(r.stats.rollbacks, 5u);  // the run did exercise rollback
    EXPECT_GT(r.stats.max_rollback_depth, 1u);
    EXPECT_LE(r.stats.max_rollback_depth, 8u);
    ASSERT_GE(r.confirmed.size(), kFrames);
    for (std::size_t i = 0; i < r.confirmed.size(); ++i) {
        ASSERT_EQ(r.confirmed[i].frame, i + 1);
        EXPECT_EQ(r.confirmed[i].checksum, reference[i + 1]) << "frame " << i + 1;
    }
    // The live state too, once its remaining guesses are confirmed.
    while (delivered < r.sync.frame()) r.sync.add_remote_input(1, delivered, script.at(1, delivered)), ++delivered;
    r.sync.rollback_if_needed();
    EXPECT_EQ(live_checksum(r.sim), reference[r.sync.frame()]);
    for (std::uint32_t f = 0; f <= r.sync.frame(); ++f)
        if (const auto s = r.sync.saved_state(f)) {
            EXPECT_EQ(r.sim.checksum(*s), reference[f]) << "saved " << f;
        }
}

TEST(SyncCore, SnapshotRingHoldsTheWindowAndTheEvidence) {
    constexpr int kWindow = 4;
    constexpr int kEvidence = 3;
    Rig r(config(2, kWindow, kEvidence));
    ASSERT_EQ(r.sync.ring().slots(), 8u);
    ASSERT_TRUE(r.sync.saved_state(0).has_value());
    EXPECT_EQ(r.sim.checksum(*r.sync.saved_state(0)), r.sync.initial_checksum());
    // The remote stream lags by the whole window: the oldest guess is kWindow frames back.
    for (std::uint32_t f = 0; f < 20; ++f) {
        if (f >= kWindow) r.sync.add_remote_input(1, f - kWindow, kNeutral);
        ASSERT_TRUE(r.tick(kNeutral)) << f;
    }
    EXPECT_EQ(r.sync.frame(), 20u);
    EXPECT_TRUE(r.sync.must_wait(0));
    for (std::uint32_t f = 0; f <= 12; ++f) EXPECT_FALSE(r.sync.saved_state(f).has_value()) << f;
    for (std::uint32_t f = 13; f <= 20; ++f) EXPECT_TRUE(r.sync.saved_state(f).has_value()) << f;
    EXPECT_FALSE(r.sync.saved_state(21).has_value());
    // The deepest rollback the window allows still finds its state.
    EXPECT_EQ(r.sync.add_remote_input(1, 16, kForward), InputQueue::Add::Stored);
    EXPECT_EQ(r.sync.rollback_if_needed(), static_cast<std::uint32_t>(kWindow));
    // No evidence asked for: one slot is kept anyway.
    Rig bare(config(2, kWindow, 0));
    EXPECT_EQ(bare.sync.ring().slots(), static_cast<std::size_t>(kWindow) + 2u);
}

TEST(SyncCore, PredictionWindowSwitchesMidGame) {
    Rig r(config(2, 6));
    EXPECT_THROW(r.sync.set_prediction_window(7), std::invalid_argument);  // the ring holds 6
    EXPECT_THROW(r.sync.set_prediction_window(-1), std::invalid_argument);
    for (std::uint32_t f = 0; f < 3; ++f) ASSERT_TRUE(r.tick(kNeutral));
    r.sync.set_prediction_window(0);  // lockstep: frames 0..2 rest on guesses
    EXPECT_EQ(r.sync.prediction_window(), 0);
    EXPECT_TRUE(r.sync.must_wait(0));
    for (std::uint32_t f = 0; f < 3; ++f) r.sync.add_remote_input(1, f, kNeutral);
    EXPECT_TRUE(r.sync.must_wait(0));  // frame 3 itself needs its input now
    r.sync.add_remote_input(1, 3, kForward);
    EXPECT_FALSE(r.sync.must_wait(0));
    EXPECT_FALSE(r.sync.rollback_pending());  // frame 3 was not simulated
    r.recorder.simulated.clear();
    ASSERT_TRUE(r.tick(kNeutral));
    ASSERT_EQ(r.recorder.simulated.size(), 1u);
    EXPECT_EQ(r.recorder.simulated[0].predicted_mask, 0u);
    r.sync.set_prediction_window(6);
    EXPECT_FALSE(r.sync.must_wait(0));
}

TEST(SyncCore, LocalInputGoesToTheDelayedFrame) {
    Rig r(config(1, 2));
    const InputQueue& q = r.sync.queue(0);
    const auto at = [&](std::uint32_t f) { return Bytes(q.confirmed(f).begin(), q.confirmed(f).end()); };
    EXPECT_TRUE(r.sync.add_local_input(kForward, 2));  // frames 0, 1: neutral (nothing before)
    EXPECT_EQ(q.confirmed_count(), 3u);
    EXPECT_EQ(at(0), kNeutral);
    EXPECT_EQ(at(1), kNeutral);
    EXPECT_EQ(at(2), kForward);
    r.sync.step_forward();
    EXPECT_TRUE(r.sync.add_local_input(kRight, 2));  // frame 3
    r.sync.step_forward();
    // The delay shrinks to 0 at frame 2: frame 2 has its input already, the new one is dropped.
    EXPECT_FALSE(r.sync.add_local_input(kNeutral, 0));
    EXPECT_EQ(at(2), kForward);
    // The delay grows to 4 at frame 2: frames 4, 5 repeat the previous input (frame 3's).
    EXPECT_TRUE(r.sync.add_local_input(kForward, 4));
    EXPECT_EQ(q.confirmed_count(), 7u);
    EXPECT_EQ(at(4), kRight);
    EXPECT_EQ(at(5), kRight);
    EXPECT_EQ(at(6), kForward);
    // A joiner catching up sends for the match's frame (min_frame), not the one it shows.
    EXPECT_TRUE(r.sync.add_local_input(kRight, 0, 9));
    EXPECT_EQ(q.confirmed_count(), 10u);
    EXPECT_EQ(at(7), kForward);
    EXPECT_EQ(at(8), kForward);
    EXPECT_EQ(at(9), kRight);
    EXPECT_THROW(r.sync.add_local_input(Bytes{1, 2}, 0), std::invalid_argument);
}

TEST(SyncCore, HostileRemoteInputSchedulesNothing) {
    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 4; ++f) ASSERT_TRUE(r.tick(kNeutral));
    using Add = InputQueue::Add;
    EXPECT_EQ(r.sync.add_remote_input(1, 0, Bytes{1}), Add::Conflict);          // too short
    EXPECT_EQ(r.sync.add_remote_input(1, 0, Bytes(64, 9)), Add::Conflict);      // too long
    EXPECT_EQ(r.sync.add_remote_input(1, 2, kForward), Add::Gap);              // after a gap
    EXPECT_EQ(r.sync.add_remote_input(1, 0xFFFFFFFFu, kForward), Add::Gap);    // far future
    EXPECT_FALSE(r.sync.rollback_pending());
    EXPECT_EQ(r.stats.peers[1].mispredictions, 0u);
    EXPECT_EQ(r.sync.queue(1).confirmed_count(), 0u);
    EXPECT_EQ(r.sync.frame(), 4u);
}

TEST(SyncCore, RestartAtASnapshotResumesFromIt) {
    const Script script(2, 40, 8);
    const auto reference = straight_line(script, 2, 39);
    // The snapshot of frame 20 from a run that had every input.
    WorldSimulation source(make_scene(2, 2), 2);
    Bytes all;
    for (std::uint32_t f = 0; f < 20; ++f) {
        all = script.at(0, f);
        all.insert(all.end(), script.at(1, f).begin(), script.at(1, f).end());
        source.step(all);
    }
    Bytes state(source.state_size());
    state.resize(source.save_to(state).size());

    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 3; ++f) ASSERT_TRUE(r.tick(kForward));
    EXPECT_FALSE(r.sync.restart_at(20, Bytes{1, 2, 3}).empty());  // not a state: refused
    EXPECT_EQ(r.sync.frame(), 3u);
    ASSERT_EQ(r.sync.restart_at(20, state), "");
    EXPECT_EQ(r.sync.frame(), 20u);
    EXPECT_EQ(r.sync.confirmed_frame(), 20u);
    EXPECT_EQ(r.sync.queue(0).confirmed_count(), 20u);
    EXPECT_EQ(r.sync.queue(1).confirmed_count(), 20u);
    EXPECT_EQ(live_checksum(r.sim), reference[20]);
    for (std::uint32_t f = 20; f < 30; ++f) {
        r.sync.add_remote_input(1, f, script.at(1, f));
        ASSERT_TRUE(r.tick(script.at(0, f)));
    }
    ASSERT_EQ(r.confirmed.size(), 10u);
    EXPECT_EQ(r.confirmed.front().frame, 21u);
    for (const auto& c : r.confirmed) EXPECT_EQ(c.checksum, reference[c.frame]) << "frame " << c.frame;
}

// Snapshot exchange through Sync: the provider's contents of a confirmed frame (state plus every
// input held from it), loaded by a newcomer that keeps the confirmed inputs it already held past
// them; from there both confirm the straight-line run's checksums.
TEST(SyncCore, TransferContentsLoadIntoAnotherSync) {
    const Script script(2, 50, 9);
    const auto reference = straight_line(script, 2, 45);
    Rig provider(config(2, 8));
    for (std::uint32_t f = 0; f < 30; ++f) {
        provider.sync.add_remote_input(1, f, script.at(1, f));
        ASSERT_TRUE(provider.tick(script.at(0, f)));
    }
    for (std::uint32_t f = 30; f < 35; ++f) provider.sync.add_remote_input(1, f, script.at(1, f));
    ASSERT_EQ(provider.sync.confirmed_frame(), 30u);
    TransferContents t;
    EXPECT_FALSE(provider.sync.transfer_contents(1, true, t));  // the ring no longer holds it
    ASSERT_TRUE(provider.sync.transfer_contents(30, true, t));
    EXPECT_EQ(t.frame, 30u);
    ASSERT_EQ(t.streams.size(), 2u);
    EXPECT_EQ(t.streams[0].count, 0u);
    EXPECT_EQ(t.streams[1].count, 5u);
    EXPECT_EQ(Bytes(t.streams[1].inputs.begin(), t.streams[1].inputs.begin() + 3), script.at(1, 30));
    TransferContents state_only;
    ASSERT_TRUE(provider.sync.transfer_contents(30, false, state_only));
    EXPECT_EQ(state_only.state, t.state);
    EXPECT_EQ(state_only.streams[1].count, 0u);

    Rig newcomer(config(2, 8));
    for (std::uint32_t f = 0; f < 3; ++f) ASSERT_TRUE(newcomer.tick(kForward));
    for (std::uint32_t f = 0; f < 40; ++f) newcomer.sync.add_remote_input(1, f, script.at(1, f));  // held past the transfer
    TransferContents bad = t;
    bad.state = {1, 2, 3};
    EXPECT_FALSE(newcomer.sync.load_transfer(bad).empty());  // refused: nothing changed
    EXPECT_EQ(newcomer.sync.frame(), 3u);
    ASSERT_EQ(newcomer.sync.load_transfer(t), "");
    EXPECT_EQ(newcomer.sync.frame(), 30u);
    EXPECT_EQ(newcomer.sync.queue(0).confirmed_count(), 30u);
    EXPECT_EQ(newcomer.sync.queue(1).confirmed_count(), 40u);  // 30..34 from the transfer, 35..39 kept
    EXPECT_EQ(live_checksum(newcomer.sim), reference[30]);
    for (std::uint32_t f = 30; f < 40; ++f) ASSERT_TRUE(newcomer.tick(script.at(0, f)));
    ASSERT_EQ(newcomer.confirmed.size(), 10u);
    EXPECT_EQ(newcomer.confirmed.front().frame, 31u);
    for (const auto& c : newcomer.confirmed) EXPECT_EQ(c.checksum, reference[c.frame]) << "frame " << c.frame;
}

// Contract: restart_at returns why it failed "and nothing changed".
// A refused snapshot (Session::finish_transfer rejects it, asks again and keeps running, as in a
// desync recovery) must not drop a scheduled rollback: the displayed state would keep resting on
// a known misprediction, and the frames confirmed from it would carry checksums the peers do not
// share (a false desync). Failed before the fix: restart_at reset the rollback before loading.
TEST(SyncCore, FailedRestartKeepsAPendingRollback) {
    Rig r(config(2, 8));
    for (std::uint32_t f = 0; f < 4; ++f) ASSERT_TRUE(r.tick(kNeutral));
    r.sync.add_remote_input(1, 0, kForward);
    ASSERT_TRUE(r.sync.rollback_pending());
    EXPECT_FALSE(r.sync.restart_at(20, Bytes{1, 2, 3}).empty());
    EXPECT_EQ(r.sync.frame(), 4u);
    EXPECT_TRUE(r.sync.rollback_pending());
    EXPECT_EQ(r.sync.rollback_if_needed(), 4u);
}

}  // namespace
}  // namespace lockroll::rollback
