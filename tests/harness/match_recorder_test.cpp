// MatchRecorder on its own: tick figures from shown times (stalls are frames late by more than a
// period, rates count from the first frame a client showed), every confirmed checksum kept,
// local and remote input latency, samples.json read back unchanged, and a session's real
// callbacks feeding it.
#include <gtest/gtest.h>

#include "harness/match/match.h"
#include "harness/match/match_recorder.h"
#include "harness/match/scene_loader.h"
#include "rollback/session.h"

namespace lockroll::harness {
namespace {

ShownTimes every_period(std::uint32_t first, std::uint32_t last, std::uint64_t period_us, std::uint64_t t0 = 1000000) {
    ShownTimes s;
    for (std::uint32_t f = first; f <= last; ++f) s.emplace_back(f, t0 + (f - first) * period_us);
    return s;
}

TEST(TickFigures, OnTimeFramesNeverStall) {
    const TickFigures t = tick_figures(every_period(1, 121, 16667), 60);
    ASSERT_TRUE(t.measured);
    EXPECT_NEAR(t.ticks_per_second, 60.0, 0.01);
    EXPECT_EQ(t.stalled_periods, 0u);
    EXPECT_EQ(t.stall_fraction, 0.0);
}

// A frame shown late by more than one tick period is a stall even if a tick ran meanwhile
// (a 100 ms freeze at 60 Hz: five periods late).
TEST(TickFigures, AFrameLateByMoreThanAPeriodIsAStall) {
    ShownTimes s = every_period(1, 60, 16667);
    const std::uint64_t freeze_end = s.back().second + 100000;
    for (std::uint32_t f = 61; f <= 120; ++f) s.emplace_back(f, freeze_end + (f - 61) * 16667);
    const TickFigures t = tick_figures(s, 60);
    EXPECT_EQ(t.stalled_periods, 5u);  // 100 ms gap = 6 periods: the frame came 5 periods late
    EXPECT_NEAR(t.stall_fraction, 5.0 / (5 + 119), 1e-9);
    // Late by less than a period: no stall.
    ShownTimes jitter = every_period(1, 10, 16667);
    jitter[5].second += 12000;
    EXPECT_EQ(tick_figures(jitter, 60).stalled_periods, 0u);
}

// A relay client starts at frame 5-7: its rate counts the frames it showed, not all of them.
TEST(TickFigures, RateCountsFromTheFirstFrameShown) {
    const TickFigures t = tick_figures(every_period(7, 720, 16667), 60);
    EXPECT_EQ(t.intervals, 713u);
    EXPECT_NEAR(t.ticks_per_second, 60.0, 0.01);
    EXPECT_FALSE(tick_figures({{5, 100}}, 60).measured);
}

rollback::FrameSimulated simulated(std::uint32_t frame, const std::vector<std::uint8_t>& inputs, bool resim = false) {
    rollback::FrameSimulated f;
    f.frame = frame;
    f.resimulation = resim;
    f.inputs = inputs;
    return f;
}

TEST(MatchRecorder, LocalAndRemoteInputLatencyAcrossTwoRecorders) {
    const sim::SceneDesc scene = with_players(load_scene("paper"), 2);
    rollback::WorldSimulation sim0(scene, 2), sim1(scene, 2);
    MatchRecorder a(0, 2, 10, sim0, true, false), b(1, 2, 10, sim1, true, false);
    const std::array<std::uint8_t, 3> change{1, 2, 3};
    a.input_offered(1000, 4, change);  // slot 0 changes its input for frame 4 at t = 1 ms
    std::vector<std::uint8_t> inputs(6, 0);
    std::copy(change.begin(), change.end(), inputs.begin());
    a.frame_simulated(9000, simulated(5, inputs));  // slot 0 shows it 8 ms later
    std::vector<std::uint8_t> predicted(6, 0);
    b.frame_simulated(5000, simulated(5, predicted));     // slot 1 first predicts wrong...
    b.frame_simulated(31000, simulated(5, inputs, true));  // ...and shows the real one in a rollback
    ASSERT_EQ(a.samples().input_latency_local.count, 1u);
    EXPECT_DOUBLE_EQ(a.samples().input_latency_local.max, 8.0);
    const RecordedSamples ra = RecordedSamples::from_json(a.samples().to_json());
    const RecordedSamples rb = RecordedSamples::from_json(b.samples().to_json());
    const Stat remote = remote_input_latency({&ra, &rb});
    ASSERT_EQ(remote.count, 1u);
    EXPECT_DOUBLE_EQ(remote.max, 30.0);
}

// A real session drives the recorder: shown frames once each, every confirmed checksum, the
// final one, CPU per tick and the physics steps, all read back from samples.json as recorded.
TEST(MatchRecorder, FedByASessionAndReadBackUnchanged) {
    const sim::SceneDesc scene = with_players(load_scene("paper"), 2);
    rollback::WorldSimulation sim(scene, 2);
    MatchRecorder rec(0, 2, 30, sim, false, true);
    struct Observer final : rollback::SessionObserver {
        MatchRecorder& r;
        rollback::Session* s = nullptr;
        std::uint64_t now = 0;
        explicit Observer(MatchRecorder& m) : r(m) {}
        void on_frame_simulated(const rollback::FrameSimulated& f) override { r.frame_simulated(now, f); }
        void on_rollback_begin(const rollback::RollbackInfo&) override { r.rollback_begin(); }
        void on_rollback_end(const rollback::RollbackInfo& i) override { r.rollback_end(i); }
        void on_frame_confirmed(const rollback::FrameConfirmed& f) override { r.frame_confirmed(f, s->saved_state(f.frame)); }
    } obs(rec);
    rollback::SessionConfig sc;
    sc.players = 2;
    sc.local_player = 0;
    sc.input_size = rollback::kWorldInputSize;
    sc.tick_rate = 60;
    sc.prediction_window = 8;
    rollback::Session session(sc, sim, &obs);
    obs.s = &session;
    // No peer: slot 1 is predicted until the window is full, then the session stalls; the
    // frames it showed are what the recorder must hold, once each.
    for (int tick = 0; tick < 20; ++tick) {
        obs.now = 1000000 + static_cast<std::uint64_t>(tick) * 16667;
        const std::array<std::uint8_t, 3> in{static_cast<std::uint8_t>(tick % 3), 0, 0};
        rec.input_offered(obs.now, session.frame(), in);
        const rollback::AdvanceResult r = session.advance(in, obs.now);
        rec.tick(static_cast<double>(r.forward_ns) / 1000.0, static_cast<double>(r.resim_ns) / 1000.0);
    }
    const RecordedSamples& s = rec.samples();
    ASSERT_GE(s.shown.size(), 1u);
    for (std::size_t k = 1; k < s.shown.size(); ++k) EXPECT_EQ(s.shown[k].first, s.shown[k - 1].first + 1);
    EXPECT_EQ(rec.shown_positions().size(), s.shown.size());
    EXPECT_EQ(s.cpu_us_per_tick.count, 20u);
    const RecordedSamples back = RecordedSamples::from_json(nlohmann::json::parse(s.to_json().dump()));
    EXPECT_EQ(back.to_json(), s.to_json());
    EXPECT_EQ(back.shown, s.shown);
    EXPECT_EQ(back.confirmed, s.confirmed);
    EXPECT_EQ(back.cpu_us_per_tick.samples, s.cpu_us_per_tick.samples);
}

// Confirmations: every one kept in order, the last frame's as the final checksum, shown against
// confirmed measured only for frames this client showed.
TEST(MatchRecorder, KeepsEveryConfirmedChecksumAndTheFinal) {
    const sim::SceneDesc scene = with_players(load_scene("paper"), 2);
    rollback::WorldSimulation sim(scene, 2);
    MatchRecorder rec(0, 2, 3, sim, false, false);
    std::vector<std::uint8_t> inputs(6, 0);
    for (std::uint32_t f = 1; f <= 4; ++f) {
        rollback::FrameConfirmed c;
        c.frame = f;
        c.checksum = 100 + f;
        c.inputs = inputs;
        rec.frame_confirmed(c, std::nullopt);
    }
    ASSERT_EQ(rec.samples().confirmed.size(), 3u);  // frame 4 is past the target
    EXPECT_EQ(rec.samples().confirmed[2], (std::pair<std::uint32_t, std::uint64_t>{3, 103}));
    ASSERT_TRUE(rec.final_checksum());
    EXPECT_EQ(*rec.final_checksum(), 103u);
    EXPECT_EQ(rec.samples().displayed_vs_confirmed.count, 0u);
}

}  // namespace
}  // namespace lockroll::harness
