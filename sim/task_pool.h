// The built-in job system of a parallel step: a fixed set of std::threads that run a batch of
// tasks and return when all are done (World::set_workers; a game with its own job system hands
// the world a TaskRunner instead, sim/world.h).
//
// Contract of run(count, task): task(i) is called exactly once for every i in [0, count), by
// the calling thread and the pool's threads (any of them, in any order, concurrently), and
// run() returns only after every call has returned. A task that throws does not stop the
// others; run() rethrows the first exception once all have finished. run() is not reentrant
// and not for two threads at once: one world steps on one thread at a time. It never
// allocates: a batch is a pointer and an atomic cursor.
//
// Waiting: run() returns as soon as every task has returned; it never waits for a pool thread
// that took no task (one still waking up finds the batch used up). Pool threads poll for the
// next batch for a bounded time, then sleep; the caller polls for tasks still running on
// other threads, then sleeps (sim/task_pool.cpp says how long, and why).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

namespace lockroll::sim {

class TaskPool {
public:
    // workers >= 1: workers - 1 threads plus the caller of run(); throws std::invalid_argument
    // naming the count otherwise (a programming error).
    explicit TaskPool(int workers);
    ~TaskPool();
    TaskPool(const TaskPool&) = delete;
    TaskPool& operator=(const TaskPool&) = delete;

    int workers() const { return static_cast<int>(threads_.size()) + 1; }
    void run(std::size_t count, const std::function<void(std::size_t)>& task);

private:
    struct Batch;  // sim/task_pool.cpp
    void work();
    std::unique_ptr<Batch> batch_;
    std::vector<std::thread> threads_;
};

}  // namespace lockroll::sim
