// How a step runs its phases: the cut into ranges, the runner's contract checked, and the
// overflow counter kept exact whichever thread ran a task.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "sim/parallel_tasks.h"

namespace lockroll::sim {
namespace {

void run_inline(std::size_t count, const std::function<void(std::size_t)>& task) {
    for (std::size_t i = 0; i < count; ++i) task(i);
}

void run_on_threads(std::size_t count, const std::function<void(std::size_t)>& task) {
    std::vector<std::thread> threads;
    for (std::size_t i = count; i-- > 0;) threads.emplace_back([&task, i] { task(i); });
    for (std::thread& t : threads) t.join();
}

// Saturates once: Fixed::max() + 1 ulp.
void overflow_once() {
    volatile std::int64_t one = 1;
    const Fixed r = Fixed::max() + Fixed::from_raw(one);
    EXPECT_EQ(r, Fixed::max());
}

TEST(ParallelTasks, RejectsABadCountOrAnEmptyRunner) {
    try {
        ParallelTasks t(0, run_inline);
        FAIL() << "count 0 accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("task count must be at least 1 (got 0)"), std::string::npos) << e.what();
    }
    try {
        ParallelTasks t(2, TaskRunner{});
        FAIL() << "empty runner accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("runner is empty"), std::string::npos) << e.what();
    }
}

TEST(ParallelTasks, SequentialRunsInOrderWithoutARunner) {
    const ParallelTasks t;
    EXPECT_FALSE(t.parallel());
    std::vector<std::size_t> order;
    t.run(4, [&](std::size_t i) { order.push_back(i); });
    EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3}));
    std::vector<std::pair<std::size_t, std::size_t>> ranges;
    t.for_ranges(1000, 10, [&](std::size_t b, std::size_t e) { ranges.emplace_back(b, e); });
    EXPECT_EQ(ranges, (std::vector<std::pair<std::size_t, std::size_t>>{{0, 1000}}));
}

TEST(ParallelTasks, RangesCoverEveryItemOnceWithinTheGrain) {
    const ParallelTasks t(4, run_on_threads);
    for (std::size_t n : {0u, 1u, 99u, 100u, 250u, 1001u}) {
        std::vector<int> hits(n, 0);
        std::vector<std::pair<std::size_t, std::size_t>> ranges(4, {0, 0});
        std::atomic<int> pieces{0};
        t.for_ranges(n, 100, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) ++hits[i];  // ranges are disjoint: no race
            pieces.fetch_add(1);
            EXPECT_GE(e - b, n < 200 ? std::size_t{0} : std::size_t{100}) << "n " << n;
        });
        for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(hits[i], 1) << "n " << n << " item " << i;
        EXPECT_EQ(static_cast<std::size_t>(pieces.load()), n == 0 ? 0 : t.piece_count(n, 100)) << "n " << n;
        EXPECT_LE(t.piece_count(n, 100), 4u);
    }
    EXPECT_EQ(t.piece_count(1001, 100), 4u);
    EXPECT_EQ(t.piece_count(250, 100), 2u);
}

TEST(ParallelTasks, ARunnerThatSkipsATaskIsAnError) {
    const ParallelTasks t(3, [](std::size_t count, const std::function<void(std::size_t)>& task) {
        for (std::size_t i = 1; i < count; ++i) task(i);
    });
    try {
        t.run(3, [](std::size_t) {});
        FAIL() << "skipped task not reported";
    } catch (const std::logic_error& e) {
        EXPECT_NE(std::string(e.what()).find("ran 2 of 3 tasks"), std::string::npos) << e.what();
    }
}

TEST(ParallelTasks, OverflowsOnOtherThreadsCountOnTheSteppingThread) {
    for (const TaskRunner& runner : {TaskRunner(run_on_threads), TaskRunner(run_inline)}) {
        const ParallelTasks t(4, runner);
        const std::uint64_t before = overflow_events();
        t.run(5, [](std::size_t i) {
            for (std::size_t k = 0; k <= i; ++k) overflow_once();
        });
        EXPECT_EQ(overflow_events() - before, 1u + 2u + 3u + 4u + 5u);  // once each, never twice
    }
}

}  // namespace
}  // namespace lockroll::sim
