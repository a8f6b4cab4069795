// A child process of the lockroll program (live starts peers and proxies): spawned with its
// stdout on a pipe we read line by line without blocking, its stderr into a file; stopped by id
// only (SIGTERM, then SIGKILL); reaped without blocking. Never a shell, never a broad kill.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace lockroll::harness {

class ChildProcess {
public:
    // Starts argv[0] (a path) with argv; stderr (and stdout when !capture_stdout) appended to
    // log_path. Throws std::runtime_error when it cannot start.
    ChildProcess(const std::vector<std::string>& argv, const std::string& log_path, bool capture_stdout);
    ~ChildProcess();  // kills (SIGKILL) and reaps a child still running
    ChildProcess(const ChildProcess&) = delete;
    ChildProcess& operator=(const ChildProcess&) = delete;

    pid_t pid() const { return pid_; }
    int stdout_fd() const { return fd_; }  // -1 when not captured or closed
    // Reads what is available (non-blocking) and returns the complete lines; at most max_bytes
    // buffered for an unfinished line (the rest dropped), so a chatty child cannot grow memory.
    std::vector<std::string> read_lines(std::size_t max_bytes = 1 << 16);
    // Reaps the child if it has exited; its status then: exit code, or 128 + signal.
    std::optional<int> poll_exit();
    bool running() { return !poll_exit().has_value(); }
    void signal(int sig);
    // SIGTERM, wait up to grace_ms, then SIGKILL; returns the status.
    int stop(int grace_ms);

private:
    pid_t pid_ = -1;
    int fd_ = -1;
    std::string partial_;
    std::optional<int> status_;
};

}  // namespace lockroll::harness
