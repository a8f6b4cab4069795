// relay_bench's parts share these (bench/relay_bench.cpp says what the benchmark measures): the
// load every run offers (two-player rooms of 60 Hz bot inputs), the command line's options, and
// what a run measures (RunResult, with its paired echo runs' EchoResult). Every part reads time
// from now_us(), the monotonic clock in microseconds.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lockroll::bench {

inline std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
}

// The load: rooms of two bots, each sending a 3-byte input a tick at 60 Hz.
inline constexpr int kPlayers = 2;
inline constexpr std::size_t kInputSize = 3;
inline constexpr int kTickRate = 60;
inline constexpr std::uint64_t kPeriodUs = 1000000 / kTickRate;

struct Options {
    std::string server;
    std::string connect;  // HOST:PORT of a server started by hand (then --server-pid for its CPU)
    int server_pid = 0;
    std::vector<int> rooms{100, 250, 500, 1000, 1500};
    double seconds = 10;
    double warmup = 3;
    int repeat = 3;
    int hosts = 64;
    int input_delay = 2;
    double ramp_rooms_per_s = 250;
    int server_cpu = 0;
    int client_cpu = 1;
    int nice = 0;
    double goal_us = 2000;
    bool verbose = false;
    std::string csv;
    std::vector<std::string> server_args;
    std::string echo;  // bench/udp_echo: the one-syscall-per-datagram baseline, run after each server run
    int echo_batch = 0;  // with echo: also udp_echo --batch echo_batch (0: not)
    int echo_pass_us = 0;  // the batched echo's --pass-us (0: a pass per wake-up)
    std::string replaced_log;  // CSV of replaced slot-frames per second, room and slot
    std::string delay_log;     // CSV of the relay delay and the generator's lateness per second
};

// One echo run's CPU (share of one core; sys its kernel part) and the datagrams a second it
// was sent (in) and sent back (out).
struct EchoResult {
    double cpu = 0, sys = 0, in_per_s = 0, out_per_s = 0;
    double receive_calls = 0, send_calls = 0;  // per datagram in, over the echo's whole life (its count line)
};

struct RunResult {
    int rooms = 0;
    int rooms_live = 0;
    double p50_us = 0, p99_us = 0, max_us = 0;
    std::uint64_t samples = 0;
    std::uint64_t replaced = 0;        // slot-frames confirmed as replaced in the window
    std::uint64_t unsent = 0;          // frames confirmed before the generator sent them
    double relay_in_per_s = 0, relay_out_per_s = 0;  // server counters (relay messages)
    double udp_in_per_s = 0, udp_out_per_s = 0;      // generator's ENet counters (seen from the server)
    double server_cpu = 0;             // share of one core
    double server_sys = 0;             // of which in the kernel (stime)
    double server_rss_mib = 0;
    double client_cpu = 0;
    double late_p99_us = 0, late_max_us = 0;  // generator tick lateness
    double loadavg = 0;
    std::uint64_t disconnects = 0;
    bool sustained = false;
    // The paired echo runs (--echo, --echo-batch): their CPU at the server run's UDP datagram rate.
    EchoResult echo, batched;
};

}  // namespace lockroll::bench
