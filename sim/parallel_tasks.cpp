#include "sim/parallel_tasks.h"

#include <stdexcept>
#include <string>

namespace lockroll::sim {

ParallelTasks::ParallelTasks(int chunks, TaskRunner runner) : chunks_(chunks), runner_(std::move(runner)) {
    if (chunks < 1)
        throw std::invalid_argument("parallel step: the task count must be at least 1 (got " + std::to_string(chunks) +
                                    ")");
    if (!runner_) throw std::invalid_argument("parallel step: the task runner is empty");
}

void ParallelTasks::run_parallel(std::size_t count, const std::function<void(std::size_t)>& task) const {
    // What tasks on other threads counted, and how many tasks ran (the contract check).
    struct Phase {
        const std::function<void(std::size_t)>* task;
        std::thread::id stepper;
        std::atomic<std::uint64_t> overflows{0};
        std::atomic<std::size_t> ran{0};
    } phase{&task, std::this_thread::get_id()};
    const std::function<void(std::size_t)> wrapped = [p = &phase](std::size_t i) {
        const bool other = std::this_thread::get_id() != p->stepper;
        const std::uint64_t before = overflow_events();
        (*p->task)(i);
        if (other) p->overflows.fetch_add(overflow_events() - before, std::memory_order_relaxed);
        p->ran.fetch_add(1, std::memory_order_relaxed);
    };
    runner_(count, wrapped);
    note_overflows(phase.overflows.load());
    if (phase.ran.load() != count)
        throw std::logic_error("parallel step: the task runner ran " + std::to_string(phase.ran.load()) + " of " +
                               std::to_string(count) + " tasks before returning (each must run exactly once)");
}

}  // namespace lockroll::sim
