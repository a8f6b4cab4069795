// The processes relay_bench starts and measures: lockroll-server and the echo baseline
// (bench/udp_echo), started pinned to the server's CPU at the server's nice and stopped again;
// a process's CPU time and RSS from /proc, the machine's load, the server's status file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bench/relay_bench.h"

namespace lockroll::bench {

// utime + stime of a process, in seconds (stime alone in *sys_s: the kernel's share).
double process_cpu_s(int pid, double* sys_s = nullptr);
double rss_mib(int pid);
double loadavg();
// The server's status file: a flat JSON object of numbers (server/server_process.cpp); -1 when
// the key is not there.
double status_number(const std::string& path, const std::string& key);
// Pins the calling process to cpu (-1: leaves it where it is).
void pin_to(int cpu);

struct ServerChild {
    int pid = 0;
    std::uint16_t port = 0;
    std::string status_file;
};

// Starts args[0] pinned to the server's CPU at the server's nice, its stderr to log, and waits
// (bounded) for its "ready PORT" line: lockroll-server, or the echo baseline (bench/udp_echo).
ServerChild spawn_ready(const Options& o, std::vector<std::string> args, const std::string& log);
// lockroll-server (o.server) for a run of `rooms` rooms on a free port of 127.0.0.1, sized as a
// deployment would size it, with o.server_args; its status file and log in dir.
ServerChild start_server(const Options& o, int rooms, const std::string& dir);
// SIGTERM, then SIGKILL when it has not exited within 5 s.
void stop_server(const ServerChild& s);

}  // namespace lockroll::bench
