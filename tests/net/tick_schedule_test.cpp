// RunEnd: how a real-time run ends, as both runners' loop (run_ticks) asks it every tick. Virtual
// microseconds only: no clock, no socket. Issue 21: a run that ends while its session is cut off
// from a majority ends Partitioned, never Completed or a timeout.
#include <gtest/gtest.h>

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
}

}  // namespace
}  // namespace lockroll::net
