// The built-in job system: every task once, all done on return, exceptions after the batch,
// threads reused batch after batch, and a clear error for a worker count below one.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <atomic>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <mutex>
#include <vector>

#include "sim/task_pool.h"

namespace lockroll::sim {
namespace {

TEST(TaskPool, RunsEveryTaskExactlyOnceBeforeReturning) {
    TaskPool pool(3);
    EXPECT_EQ(pool.workers(), 3);
    std::vector<std::atomic<int>> calls(1000);
    pool.run(calls.size(), [&](std::size_t i) { calls[i].fetch_add(1); });
    for (std::size_t i = 0; i < calls.size(); ++i) ASSERT_EQ(calls[i].load(), 1) << "task " << i;
}

TEST(TaskPool, ReusesItsThreadsAcrossBatches) {
    TaskPool pool(4);
    std::mutex m;
    std::set<std::thread::id> seen;
    std::atomic<std::size_t> total{0};
    for (int batch = 0; batch < 500; ++batch)
        pool.run(8, [&](std::size_t) {
            total.fetch_add(1);
            const std::lock_guard lock(m);
            seen.insert(std::this_thread::get_id());
        });
    EXPECT_EQ(total.load(), 500u * 8u);
    // The caller and at most three pool threads, whoever took the tasks.
    EXPECT_GE(seen.size(), 1u);
    EXPECT_LE(seen.size(), 4u);
}

// The handoff a parallel step pays per phase (a step has about a dozen): the caller of run()
// must not block on the pool's threads unless one of them is still running a task it took.
// With a condition variable alone the caller slept on nearly every batch, waiting for a
// worker to wake up only to find the tasks done (bodies_10k ran slower on two workers than
// on one, docs/performance.md "Parallel step"). Voluntary context switches of the calling
// thread count those sleeps; half the batches leaves room for a loaded machine.
TEST(TaskPool, CallerDoesNotSleepOnTheHandoff) {
    TaskPool pool(2);
    std::atomic<std::size_t> ran{0};
    constexpr int kBatches = 1000;
    rusage before{}, after{};
    getrusage(RUSAGE_THREAD, &before);
    for (int batch = 0; batch < kBatches; ++batch) pool.run(2, [&](std::size_t) { ran.fetch_add(1); });
    getrusage(RUSAGE_THREAD, &after);
    EXPECT_EQ(ran.load(), 2u * kBatches);
    EXPECT_LT(after.ru_nvcsw - before.ru_nvcsw, kBatches / 2);
}

TEST(TaskPool, OneWorkerRunsOnTheCallingThreadInOrder) {
    TaskPool pool(1);
    std::vector<std::size_t> order;
    const auto caller = std::this_thread::get_id();
    pool.run(5, [&](std::size_t i) {
        EXPECT_EQ(std::this_thread::get_id(), caller);
        order.push_back(i);
    });
    EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
}

TEST(TaskPool, RethrowsTheFirstExceptionAfterEveryTaskRan) {
    TaskPool pool(2);
    std::atomic<int> ran{0};
    EXPECT_THROW(pool.run(100,
                          [&](std::size_t i) {
                              ran.fetch_add(1);
                              if (i == 7) throw std::runtime_error("task 7");
                          }),
                 std::runtime_error);
    EXPECT_EQ(ran.load(), 100);
    // The pool stays usable.
    ran = 0;
    pool.run(10, [&](std::size_t) { ran.fetch_add(1); });
    EXPECT_EQ(ran.load(), 10);
}

TEST(TaskPool, EmptyBatchReturnsAtOnce) {
    TaskPool pool(2);
    bool called = false;
    pool.run(0, [&](std::size_t) { called = true; });
    EXPECT_FALSE(called);
}

TEST(TaskPool, RejectsFewerThanOneWorker) {
    for (int bad : {0, -3}) {
        try {
            TaskPool pool(bad);
            FAIL() << "TaskPool(" << bad << ") did not throw";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("at least 1"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(std::to_string(bad)), std::string::npos) << e.what();
        }
    }
}

}  // namespace
}  // namespace lockroll::sim
