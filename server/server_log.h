// ServerLog: the relay server's log, written off the relay loop (issue 20). The loop formats a
// line and hands it to a bounded queue (spdlog's async logger over a thread pool of its own, one
// worker); the worker writes it to the sink (stderr). The loop never waits on the sink: a
// stderr that is a pipe nobody reads (a supervisor that stalls, a full journald) blocks write()
// once its 64 KiB are full, and a loop that wrote its own log lines stopped every room with it,
// for as long as the reader did -- and a hostile client makes a warn line per refused hello.
// When the queue is full the oldest line waiting is dropped for the new one
// (async_overflow_policy::overrun_oldest): under pressure the log keeps the newest lines and
// counts the others (dropped()); report_dropped() writes the count as a line of its own, so the
// gap shows in the log once the sink takes lines again.
// close() writes what is queued and joins the worker, waiting at most a bound: on a clean exit
// nothing queued is lost; a sink that never takes it does not hold the process.
// Not thread-safe apart from what spdlog's logger is (the loop logs, nothing else).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

namespace spdlog {
class logger;
class async_logger;
namespace sinks {
class sink;
}
namespace details {
class thread_pool;
}
}  // namespace spdlog

namespace lockroll::server {

class ServerLog {
public:
    // 4,096 lines, as many as RelayServer keeps events for the log: a queue allocated once, of
    // 1.6 MB (spdlog's slots are 408 bytes, a line's first 250 inline); hours of the server's
    // ordinary lines (a few a second, on events), a few seconds of a flood.
    static constexpr std::size_t kDefaultQueueLines = 4096;
    // How long close() (and the destructor) wait for the sink at exit.
    static constexpr std::chrono::milliseconds kCloseTimeout{2000};

    // level: spdlog's names (trace ... off). sink: where lines go (nullptr: stderr, coloured on a
    // terminal), with the server's pattern.
    explicit ServerLog(const std::string& level, std::shared_ptr<spdlog::sinks::sink> sink = nullptr,
                       std::size_t queue_lines = kDefaultQueueLines);
    ~ServerLog();  // close(kCloseTimeout) unless closed
    ServerLog(const ServerLog&) = delete;
    ServerLog& operator=(const ServerLog&) = delete;

    // Never waits on the sink. After close() it logs nothing (its level is off).
    spdlog::logger& logger() const;
    spdlog::logger* operator->() const { return &logger(); }
    // Lines dropped so far because the queue was full (the oldest waiting ones).
    std::uint64_t dropped() const;
    // If lines were dropped since the last report, logs a warn line saying how many (itself
    // queued: under pressure only the newest such line survives, with the running total).
    void report_dropped();
    // Waits at most timeout for the worker to write everything queued and end, then for the
    // sink's flush. true: all written. false: the sink held it; the worker is left blocked (not
    // joined) and ends with the process. Later calls return the first one's answer.
    bool close(std::chrono::milliseconds timeout = kCloseTimeout);

private:
    std::shared_ptr<spdlog::details::thread_pool> pool_;
    std::shared_ptr<spdlog::async_logger> log_;
    std::size_t queue_lines_;
    std::FILE* err_ = nullptr;  // the default sink's stream (a copy of fd 2), closed by close()
    std::uint64_t reported_ = 0;
    bool closed_ = false;
    bool close_result_ = false;
};

}  // namespace lockroll::server
