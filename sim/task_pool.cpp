#include "sim/task_pool.h"

#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>

namespace lockroll::sim {

// One batch at a time. A thread takes tasks from `next` until it passes `count`, then counts
// itself out in `busy`; run() waits for busy == 0, so every thread has left a batch before the
// next one is published (`generation` tells the threads a new one is there).
struct TaskPool::Batch {
    std::mutex mutex;
    std::condition_variable start, done;
    const std::function<void(std::size_t)>* task = nullptr;
    std::size_t count = 0;
    std::atomic<std::size_t> next{0};
    std::uint64_t generation = 0;
    int busy = 0;
    bool stop = false;
    std::exception_ptr error;

    // Runs tasks of the current batch until none is left.
    void drain() {
        for (std::size_t i = next.fetch_add(1); i < count; i = next.fetch_add(1)) {
            try {
                (*task)(i);
            } catch (...) {
                const std::lock_guard lock(mutex);
                if (!error) error = std::current_exception();
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
        batch_->stop = true;
    }
    batch_->start.notify_all();
    for (std::thread& t : threads_) t.join();
}

void TaskPool::work() {
    Batch& b = *batch_;
    std::uint64_t seen = 0;
    for (;;) {
        {
            std::unique_lock lock(b.mutex);
            b.start.wait(lock, [&] { return b.stop || b.generation != seen; });
            if (b.stop) return;
            seen = b.generation;
        }
        b.drain();
        const std::lock_guard lock(b.mutex);
        if (--b.busy == 0) b.done.notify_one();
    }
}

void TaskPool::run(std::size_t count, const std::function<void(std::size_t)>& task) {
    if (count == 0) return;
    Batch& b = *batch_;
    if (threads_.empty() || count == 1) {
        b.task = &task;
        b.count = count;
        b.next.store(0);
        b.drain();
    } else {
        {
            const std::lock_guard lock(b.mutex);
            b.task = &task;
            b.count = count;
            b.next.store(0);
            b.busy = static_cast<int>(threads_.size());
            ++b.generation;
        }
        b.start.notify_all();
        b.drain();
        std::unique_lock lock(b.mutex);
        b.done.wait(lock, [&] { return b.busy == 0; });
    }
    b.task = nullptr;
    if (b.error) {
        std::exception_ptr e = b.error;
        b.error = nullptr;
        std::rethrow_exception(e);
    }
}

}  // namespace lockroll::sim
