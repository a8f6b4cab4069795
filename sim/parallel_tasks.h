// How a step runs its parallel phases: cut into chunks() tasks, handed to a TaskRunner (the
// world's built-in TaskPool or a game's job system, sim/world.h), with the overflow counter
// kept exact.
//
// Contracts:
//  - A phase's tasks write disjoint state, so which thread runs which task, and in what order,
//    cannot change a bit (docs/determinism.md, "Parallel step"). The cut itself is a function
//    of the sizes and chunks() only, and no phase's result depends on it either.
//  - Fixed's overflow counter is per thread (sim/fixed.h). A task that runs on another thread
//    than the one stepping adds what it counted to the stepping thread's counter when the phase
//    ends, so World::overflow_count() is the same whoever ran the tasks.
//  - Sequential (the default, chunks() == 1): every phase is one call on the stepping thread,
//    with no runner, no atomics and no allocation.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <functional>
#include <thread>

#include "sim/fixed.h"
#include "sim/world.h"

namespace lockroll::sim {

class ParallelTasks {
public:
    ParallelTasks() = default;  // sequential
    // chunks >= 1 and a runner that is set; throws std::invalid_argument naming which otherwise.
    ParallelTasks(int chunks, TaskRunner runner);

    int chunks() const { return chunks_; }
    bool parallel() const { return chunks_ > 1; }

    // Runs task(i) for every i in [0, count) through the runner (directly when sequential or
    // count <= 1). Throws std::logic_error if the runner returned having made another number
    // of task calls than count (a task skipped, or run twice).
    // Sequential, it is a plain loop over `task` (no std::function, so no allocation).
    template <class Task>
    void run(std::size_t count, Task&& task) const {
        if (!parallel() || count <= 1) {
            for (std::size_t i = 0; i < count; ++i) task(i);
            return;
        }
        // A reference wrapper always fits std::function's inline buffer: no allocation.
        const std::function<void(std::size_t)> f = std::ref(task);
        run_parallel(count, f);
    }

    // Cuts [0, n) into at most chunks() ranges of at least `grain` items (one range when
    // sequential or n < 2 grain) and runs body(begin, end) for each.
    template <class Body>
    void for_ranges(std::size_t n, std::size_t grain, Body&& body) const {
        const std::size_t pieces = piece_count(n, grain);
        if (pieces <= 1) {
            if (n > 0) body(std::size_t{0}, n);
            return;
        }
        run(pieces, [&](std::size_t k) { body(n * k / pieces, n * (k + 1) / pieces); });
    }

    // How many ranges for_ranges() cuts n items into.
    std::size_t piece_count(std::size_t n, std::size_t grain) const {
        if (!parallel()) return 1;
        return std::clamp<std::size_t>(n / std::max<std::size_t>(grain, 1), 1, static_cast<std::size_t>(chunks_));
    }

private:
    void run_parallel(std::size_t count, const std::function<void(std::size_t)>& task) const;

    int chunks_ = 1;
    TaskRunner runner_;
};

}  // namespace lockroll::sim
