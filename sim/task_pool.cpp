#include "sim/task_pool.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace lockroll::sim {

namespace {
// A batch's claim cursor is one 64-bit word: generation (16 bits) | task count (24) | next
// index (24). A thread claims a task with one fetch_add and learns from the same word which
// batch the task belongs to, so it never reads a batch that has already ended, and run() need
// not wait for threads that took no task (a late sleeper finds the batch used up and leaves
// it: the caller ran its tasks). Each thread overshoots the count at most once a batch, so the
// index never carries into the count while count + threads < 2^24.
constexpr int kIndexBits = 24;
constexpr std::uint64_t kIndexMask = (std::uint64_t{1} << kIndexBits) - 1;
constexpr std::size_t kMaxBatch = std::size_t{1} << 22;  // longer runs are cut into batches

constexpr std::uint64_t pack(std::uint64_t generation, std::uint64_t count) {
    return (generation & 0xffff) << (2 * kIndexBits) | count << kIndexBits;
}
constexpr std::uint64_t generation_of(std::uint64_t c) { return c >> (2 * kIndexBits); }
constexpr std::size_t count_of(std::uint64_t c) { return static_cast<std::size_t>((c >> kIndexBits) & kIndexMask); }
constexpr std::size_t index_of(std::uint64_t c) { return static_cast<std::size_t>(c & kIndexMask); }

// How long a pool thread polls for the next batch before it sleeps, and the caller of run()
// for tasks still running on other threads. A parallel step publishes about a dozen batches,
// most of them a few to a few tens of µs apart (the sequential parts between phases), while
// waking a sleeping thread through the kernel took 10-25 µs of CPU and 20-50 µs of latency on
// the 2-vCPU test machine (a condition-variable round trip). Polling is bounded, so a pool
// between frames (16 ms at 60 Hz) sleeps after this long: at most about 1 % of a core each.
constexpr std::chrono::microseconds kWorkerSpin{200};
constexpr std::chrono::microseconds kCallerSpin{200};

void relax() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
}

// Polls ready() until it holds or `time` has passed; true if it held. After a short burst
// it yields between polls: on a machine with more runnable threads than cores, a poller that
// kept its core would hold off the very thread it waits for (measured: bodies_10k ran 2.6
// times slower on two workers at load 3 with pure spinning); when the core is free, yield
// returns at once.
template <class Ready>
bool spin_until(std::chrono::microseconds time, Ready&& ready) {
    for (int i = 0; i < 64; ++i) {
        if (ready()) return true;
        relax();
    }
    const auto deadline = std::chrono::steady_clock::now() + time;
    for (;;) {
        std::this_thread::yield();
        for (int i = 0; i < 16; ++i) {
            if (ready()) return true;
            relax();
        }
        if (std::chrono::steady_clock::now() >= deadline) return ready();
    }
}
}  // namespace

struct TaskPool::Batch {
    std::mutex mutex;
    std::condition_variable start, done;
    // Set before the cursor publishes a batch; unchanged until all its tasks have finished.
    const std::function<void(std::size_t)>* task = nullptr;
    std::size_t offset = 0;
    std::atomic<std::uint64_t> cursor{0};
    std::atomic<std::size_t> finished{0};  // tasks of the current batch that have returned
    std::atomic<bool> stop{false};
    int workers_asleep = 0;      // under the mutex
    bool caller_asleep = false;  // under the mutex
    std::exception_ptr error;    // under the mutex

    // Claims and runs tasks of the current batch until none is left; returns that batch's
    // generation.
    std::uint64_t drain() {
        for (;;) {
            const std::uint64_t c = cursor.fetch_add(1, std::memory_order_acq_rel);
            const std::size_t n = count_of(c);
            if (index_of(c) >= n) return generation_of(c);
            try {
                (*task)(offset + index_of(c));
            } catch (...) {
                const std::lock_guard lock(mutex);
                if (!error) error = std::current_exception();
            }
            if (finished.fetch_add(1, std::memory_order_acq_rel) + 1 == n) {
                const std::lock_guard lock(mutex);
                if (caller_asleep) done.notify_one();
            }
        }
    }
};

TaskPool::TaskPool(int workers) : batch_(std::make_unique<Batch>()) {
    if (workers < 1)
        throw std::invalid_argument("TaskPool: workers must be at least 1 (got " + std::to_string(workers) + ")");
    threads_.reserve(static_cast<std::size_t>(workers - 1));
    for (int i = 1; i < workers; ++i) threads_.emplace_back([this] { work(); });
}

TaskPool::~TaskPool() {
    {
        const std::lock_guard lock(batch_->mutex);
        batch_->stop.store(true);
    }
    batch_->start.notify_all();
    for (std::thread& t : threads_) t.join();
}

void TaskPool::work() {
    Batch& b = *batch_;
    std::uint64_t seen = 0;  // the generation of the last batch this thread found used up
    const auto ready = [&] {
        return b.stop.load(std::memory_order_acquire) ||
               generation_of(b.cursor.load(std::memory_order_acquire)) != seen;
    };
    for (;;) {
        if (!spin_until(kWorkerSpin, ready)) {
            std::unique_lock lock(b.mutex);
            ++b.workers_asleep;
            b.start.wait(lock, ready);
            --b.workers_asleep;
        }
        if (b.stop.load(std::memory_order_acquire)) return;
        seen = b.drain();
    }
}

void TaskPool::run(std::size_t count, const std::function<void(std::size_t)>& task) {
    Batch& b = *batch_;
    b.task = &task;
    for (std::size_t offset = 0; offset < count; offset += kMaxBatch) {
        const std::size_t n = std::min(kMaxBatch, count - offset);
        b.offset = offset;
        b.finished.store(0, std::memory_order_relaxed);
        const std::uint64_t generation = generation_of(b.cursor.load(std::memory_order_relaxed)) + 1;
        b.cursor.store(pack(generation, n), std::memory_order_release);
        if (!threads_.empty() && n > 1) {
            bool wake;
            {
                const std::lock_guard lock(b.mutex);
                wake = b.workers_asleep > 0;
            }
            if (wake) b.start.notify_all();
        }
        b.drain();
        const auto finished = [&] { return b.finished.load(std::memory_order_acquire) == n; };
        if (!spin_until(kCallerSpin, finished)) {
            std::unique_lock lock(b.mutex);
            b.caller_asleep = true;
            b.done.wait(lock, finished);
            b.caller_asleep = false;
        }
    }
    b.task = nullptr;
    if (b.error) {
        std::exception_ptr e = b.error;
        b.error = nullptr;
        std::rethrow_exception(e);
    }
}

}  // namespace lockroll::sim
