#include "server/server_log.h"

#include <spdlog/async.h>
#include <spdlog/sinks/ansicolor_sink.h>
#include <spdlog/sinks/null_sink.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <future>
#include <thread>

namespace lockroll::server {

ServerLog::ServerLog(const std::string& level, std::shared_ptr<spdlog::sinks::sink> sink, std::size_t queue_lines) : queue_lines_(queue_lines) {
    if (!sink) {
        // stderr, through a FILE of our own on a copy of fd 2, unbuffered. Not the process's
        // stderr FILE: a worker blocked in write() on a full pipe holds its FILE's lock, and the
        // exit flushes stderr (std::cerr's ios_base::Init), which would then wait for good. Ours
        // nothing else touches; unbuffered, the exit has nothing of it to flush. No console mutex
        // either: only the worker writes.
        const int fd = ::dup(STDERR_FILENO);
        err_ = fd >= 0 ? ::fdopen(fd, "w") : nullptr;
        if (err_) {
            std::setvbuf(err_, nullptr, _IONBF, 0);
            sink = std::make_shared<spdlog::sinks::ansicolor_sink<spdlog::details::console_nullmutex>>(err_, spdlog::color_mode::automatic);
        } else {
            if (fd >= 0) ::close(fd);
            sink = std::make_shared<spdlog::sinks::null_sink_st>();  // no stderr to write to
        }
    }
    // A pool of our own, registered nowhere: its lifetime (and the join at exit) is close()'s.
    pool_ = std::make_shared<spdlog::details::thread_pool>(queue_lines, 1);
    log_ = std::make_shared<spdlog::async_logger>("server", std::move(sink), pool_, spdlog::async_overflow_policy::overrun_oldest);
    log_->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] [server] %v");
    log_->set_level(spdlog::level::from_str(level));
}

ServerLog::~ServerLog() { close(kCloseTimeout); }

spdlog::logger& ServerLog::logger() const { return *log_; }

std::uint64_t ServerLog::dropped() const { return pool_ ? pool_->overrun_counter() : reported_; }

void ServerLog::report_dropped() {
    const std::uint64_t n = dropped();
    if (n == reported_) return;
    log_->warn("log: {} lines dropped ({} in all): the log's reader fell behind by more than its queue of {} lines", n - reported_,
               n, queue_lines_);
    reported_ = n;
}

bool ServerLog::close(std::chrono::milliseconds timeout) {
    if (closed_) return close_result_;
    closed_ = true;
    reported_ = dropped();  // dropped() answers this once the pool is gone
    log_->set_level(spdlog::level::off);
    // The pool's destructor queues its end (waiting for room, never dropping a line) and joins
    // the worker once everything before it is written; then the sinks are flushed (not by
    // log_->flush(): queued into a full queue it would drop the oldest line). On a thread of its
    // own, so a sink that never takes the lines leaves only that thread (and the worker)
    // blocked, detached, for the process's exit to end.
    std::promise<void> done;
    std::future<void> joined = done.get_future();
    std::thread closer([pool = std::move(pool_), log = log_, done = std::move(done)]() mutable {
        pool.reset();
        for (const auto& sink : log->sinks()) sink->flush();
        done.set_value();
    });
    close_result_ = joined.wait_for(timeout) == std::future_status::ready;
    if (close_result_) {
        closer.join();
        if (err_) std::fclose(err_);  // the worker is gone: nothing writes to it any more
    } else {
        closer.detach();  // err_ stays open for the blocked worker
    }
    err_ = nullptr;
    return close_result_;
}

}  // namespace lockroll::server
