// RunEnd: how a real-time run ends, as both runners' loop (TickLoop) asks it every tick. Virtual
// microseconds only: no clock, no socket. Issue 21: a run that ends while its session is cut off
// from a majority ends Partitioned, never Completed or a timeout. TickLoop: the game's own loop
// calling update() at its own rate gets the ticks that are due, and an interpolation fraction.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <vector>

#include "net/tick_schedule.h"

namespace lockroll::net {
namespace {

RunnerConfig config() {
    RunnerConfig c;
    c.tick_rate = 60;
    c.target_frame = 600;            // 10 s of match
    c.finish_timeout_us = 15000000;  // so a partitioned run waits 25 s after starting
    c.run_timeout_us = 100000000;
    c.linger_us = 300000;
    return c;
}

constexpr std::uint64_t kStart = 1000000;  // when the session started running
constexpr std::uint64_t kTick = 16667;

// Ticks from `from` to `until` (exclusive) with the same status; the first verdict, if any.
std::optional<std::pair<RunOutcome, std::uint64_t>> run(RunEnd& end, std::uint64_t from, std::uint64_t until, bool shown,
                                                        bool confirmed, bool partitioned) {
    for (std::uint64_t t = from; t < until; t += kTick)
        if (auto o = end.check(t, kStart, shown, confirmed, nullptr, partitioned)) return std::pair{*o, t};
    return std::nullopt;
}

TEST(RunEnd, WithoutAPartitionTheOutcomesAreAsBefore) {
    const RunnerConfig c = config();
    RunEnd done(c);
    auto o = run(done, kStart, kStart + 20000000, true, true, false);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::Completed);
    RunEnd unconfirmed(c);
    o = run(unconfirmed, kStart, kStart + 30000000, true, false, false);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::FinishTimeout);
    RunEnd never_shown(c);
    o = run(never_shown, kStart, kStart + 200000000, false, false, false);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::RunTimeout);
    EXPECT_GT(o->second - kStart, c.run_timeout_us);
}

TEST(RunEnd, APartitionedRunNeverCompletes) {
    const RunnerConfig c = config();
    RunEnd end(c);
    const auto o = run(end, kStart, kStart + 20000000, true, true, true);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::Partitioned);
}

TEST(RunEnd, AFinishTimeoutWhilePartitionedIsPartitioned) {
    const RunnerConfig c = config();
    RunEnd end(c);
    const auto o = run(end, kStart, kStart + 30000000, true, false, true);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::Partitioned);
}

TEST(RunEnd, APartitionedRunWaitsUntilTheMatchShouldHaveEndedPlusTheFinishTimeout) {
    const RunnerConfig c = config();
    RunEnd end(c);
    EXPECT_EQ(end.partition_wait_us(), 25000000u);
    // Not before: the network may heal and the session carry on.
    EXPECT_FALSE(run(end, kStart, kStart + end.partition_wait_us(), false, false, true));
    const auto o = run(end, kStart + end.partition_wait_us(), kStart + end.partition_wait_us() + 1000000, false, false, true);
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::Partitioned);
    // Long before the run timeout (which, without a partition, ends a stalled run).
    EXPECT_LT(o->second - kStart, c.run_timeout_us);
}

TEST(RunEnd, AHealedPartitionCompletesAsUsual) {
    const RunnerConfig c = config();
    RunEnd end(c);
    EXPECT_FALSE(run(end, kStart, kStart + 5000000, false, false, true));  // cut off for 5 s
    const auto o = run(end, kStart + 5000000, kStart + 40000000, true, true, false);  // healed
    ASSERT_TRUE(o);
    EXPECT_EQ(o->first, RunOutcome::Completed);
}

TEST(RunEnd, EveryOutcomeHasAName) {
    EXPECT_STREQ(outcome_name(RunOutcome::Partitioned), "partitioned");
    EXPECT_STREQ(outcome_name(RunOutcome::Completed), "completed");
    EXPECT_STREQ(outcome_name(RunOutcome::ServerLost), "server_lost");
}

// A game loop of `hz` frames a second driving a TickLoop at 60 ticks a second, in virtual time:
// what each update() returned, and the ticks' due times as the loop passed them.
struct Driven {
    std::vector<UpdateResult> updates;
    std::vector<std::uint64_t> tick_due;
};
Driven drive(const RunnerConfig& c, int hz, std::uint64_t seconds, bool may_tick = true, std::uint64_t stop_at = 0) {
    TickLoop loop(c);
    Driven d;
    std::uint64_t now = kStart;
    std::atomic<bool> stop{false};
    const std::uint64_t frame_us = 1000000u / static_cast<std::uint64_t>(hz);
    for (std::uint64_t t = kStart; t < kStart + seconds * 1000000u; t += frame_us) {
        now = t;
        if (stop_at && t >= stop_at) stop.store(true);
        d.updates.push_back(loop.update(
            [&] { return now; }, stop, nullptr, [&](std::uint64_t) { return may_tick; },
            [&](std::uint64_t, std::uint64_t due) {
                d.tick_due.push_back(due);
                return TickDone{0, 0};
            },
            [] { return TickStatus{.running = true}; }));
        if (d.updates.back().outcome) break;
    }
    return d;
}

int most_frames(const Driven& d) {
    int m = 0;
    for (const auto& u : d.updates) m = std::max(m, u.frames);
    return m;
}

TEST(TickLoop, AGameSlowerThanTheTickRateGetsSeveralTicksPerUpdate) {
    const Driven d = drive(config(), 30, 2);
    std::size_t ticks = 0;
    for (const auto& u : d.updates) ticks += static_cast<std::size_t>(u.frames);
    EXPECT_EQ(ticks, d.tick_due.size());
    EXPECT_NEAR(static_cast<double>(ticks), 120.0, 2.0);  // 2 s at 60 Hz, whatever the game's rate
    EXPECT_EQ(most_frames(d), 2);
    // Ticks run at their due times' pace: 60 a second.
    EXPECT_EQ(d.tick_due[60] - d.tick_due[0], 1000000u);
}

TEST(TickLoop, AGameFasterThanTheTickRateGetsNoneOrOneAndAnInterpolationBetweenThem) {
    const Driven d = drive(config(), 144, 2);
    std::size_t ticks = 0, none = 0;
    for (const auto& u : d.updates) {
        ticks += static_cast<std::size_t>(u.frames);
        none += u.frames == 0;
        EXPECT_GE(u.interpolation, 0.0);
        EXPECT_LT(u.interpolation, 1.0);
    }
    EXPECT_NEAR(static_cast<double>(ticks), 120.0, 2.0);
    EXPECT_EQ(most_frames(d), 1);
    EXPECT_GT(none, d.updates.size() / 3);  // 144 frames for 60 ticks a second
    // Between two ticks the fraction grows; at a tick it starts again near 0.
    bool grew = false;
    for (std::size_t i = 1; i < d.updates.size(); ++i)
        if (d.updates[i].frames == 0 && d.updates[i - 1].frames == 0) {
            EXPECT_GT(d.updates[i].interpolation, d.updates[i - 1].interpolation) << i;
            grew = true;
        }
    EXPECT_TRUE(grew);
}

TEST(TickLoop, AFrozenGameDoesNotFastForwardInABurst) {
    RunnerConfig c = config();
    TickLoop loop(c);
    std::atomic<bool> stop{false};
    std::uint64_t now = kStart;
    const auto update = [&] {
        return loop.update([&] { return now; }, stop, nullptr, [](std::uint64_t) { return true; },
                           [](std::uint64_t, std::uint64_t) { return TickDone{0, 3}; }, [] { return TickStatus{.running = true}; });
    };
    EXPECT_EQ(update().frames, 1);
    now += 5000000;  // the game froze for 5 s
    const UpdateResult r = update();
    EXPECT_LE(r.frames, c.max_catch_up + 1);
    EXPECT_EQ(r.rollback_depth, 3u);
    EXPECT_EQ(loop.schedule_resets(), 1u);
}

TEST(TickLoop, StopAndConnectTimeoutEndTheRunOnce) {
    const Driven stopped = drive(config(), 60, 5, true, kStart + 1000000);
    ASSERT_TRUE(stopped.updates.back().outcome);
    EXPECT_EQ(*stopped.updates.back().outcome, RunOutcome::Stopped);
    RunnerConfig c = config();
    c.connect_timeout_us = 2000000;
    const Driven waiting = drive(c, 60, 5, false);  // the runner's connections never come up
    EXPECT_TRUE(waiting.tick_due.empty());
    ASSERT_TRUE(waiting.updates.back().outcome);
    EXPECT_EQ(*waiting.updates.back().outcome, RunOutcome::ConnectTimeout);
    EXPECT_NEAR(static_cast<double>(waiting.updates.size()) / 60.0, 2.0, 0.1);
}

// Updates `loop` once a tick from `now` until its run is over (at most 200 updates), each tick
// counted in `ticks`; the outcome, if it came.
std::optional<RunOutcome> update_until_over(TickLoop& loop, std::uint64_t& now, int& ticks, const std::function<TickStatus()>& status) {
    std::atomic<bool> stop{false};
    std::optional<RunOutcome> o;
    for (int i = 0; i < 200 && !o; ++i, now += kTick)
        o = loop.update([&] { return now; }, stop, nullptr, [](std::uint64_t) { return true; },
                        [&](std::uint64_t, std::uint64_t) { return ++ticks, TickDone{}; }, status)
                .outcome;
    return o;
}

// A failed session ends the run Failed, or ServerLost when it failed on the relay server's
// silence: the outcome names a dead server.
TEST(TickLoop, AFailureOnTheServersSilenceIsServerLost) {
    const RunnerConfig c = config();  // the loop keeps a reference to it
    TickLoop failed(c), lost(c);
    std::uint64_t now = kStart;
    int ticks = 0;
    EXPECT_EQ(update_until_over(failed, now, ticks, [&] { return TickStatus{.failed = ticks >= 5, .running = true}; }),
              RunOutcome::Failed);
    ticks = 0;
    EXPECT_EQ(update_until_over(lost, now, ticks,
                                [&] { return TickStatus{.failed = ticks >= 5, .running = true, .server_lost = ticks >= 5}; }),
              RunOutcome::ServerLost);
}

// A session that never ran by the connect timeout (a joiner) ends ConnectTimeout, or Partitioned
// when it is cut off from a majority then (rollback/joiner_reach.h): the outcome names the cause.
TEST(TickLoop, AJoinerCutOffAtTheConnectTimeoutEndsPartitioned) {
    RunnerConfig c = config();
    c.connect_timeout_us = 2000000;
    TickLoop cut_off(c), waiting(c);
    std::uint64_t now = kStart;
    int ticks = 0;
    EXPECT_EQ(update_until_over(cut_off, now, ticks, [&] { return TickStatus{.partitioned = ticks >= 60}; }),
              RunOutcome::Partitioned);
    EXPECT_NEAR(static_cast<double>(ticks) / 60.0, 2.0, 0.1) << "at the connect timeout, not before";
    now = kStart;
    ticks = 0;
    EXPECT_EQ(update_until_over(waiting, now, ticks, [] { return TickStatus{}; }), RunOutcome::ConnectTimeout);
}

TEST(TickLoop, ARunThatIsOverStaysOver) {
    RunnerConfig c = config();
    c.target_frame = 10;
    TickLoop loop(c);
    std::atomic<bool> stop{false};
    std::uint64_t now = kStart;
    int ticks = 0;
    const std::optional<RunOutcome> first = update_until_over(
        loop, now, ticks, [&] { return TickStatus{.running = true, .shown_target = ticks >= 10, .confirmed = ticks >= 10}; });
    ASSERT_TRUE(first);
    EXPECT_EQ(*first, RunOutcome::Completed);
    const int at_end = ticks;
    now += 1000000;
    const UpdateResult again = loop.update([&] { return now; }, stop, nullptr, [](std::uint64_t) { return true; },
                                           [&](std::uint64_t, std::uint64_t) { return ++ticks, TickDone{}; },
                                           [] { return TickStatus{}; });
    EXPECT_EQ(again.outcome, first);
    EXPECT_EQ(again.frames, 0);
    EXPECT_EQ(ticks, at_end);
    EXPECT_FALSE(loop.next_due());
}

}  // namespace
}  // namespace lockroll::net
