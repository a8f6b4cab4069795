// relay_bench: how many two-player rooms one lockroll-server process sustains on one core.
//
// A load generator on loopback. For each room count R of a sweep it starts one lockroll-server
// (pinned to --server-cpu; the generator pins itself to --client-cpu), connects 2R ENet client
// peers spread over a few ENet hosts, and speaks the relay protocol directly
// (rollback/relay_messages.h): every peer says hello for its room and slot, then sends one
// RelayInput per tick at 60 Hz, as a client with an input delay of --input-delay frames would
// (its input for frame f leaves while the room clock is about f - delay). Rooms are spread
// evenly over the tick: host g carries the rooms of phase g / hosts, and sends all of them in
// one flush.
//
// Relay delay of frame f: from the flush that sent the later of the room's two inputs for f to
// the receipt, by each of the two clients, of the first Frames message that carries f (one
// sample per client and frame; loopback both ways, ENet on both ends and the generator's own
// event handling are included). Reported per run over the measurement window: p50 / p99 delay,
// replaced inputs (frames the server confirmed without a slot's input: the deadline passed),
// relay datagrams per second in and out (the server's own counters, from its status file), UDP
// datagrams the generator sent and received (ENet's counters: pings and acks included), the
// server's CPU (utime + stime from /proc/PID/stat over the window, as a share of one core; stime
// alone as its kernel share) and
// its RSS at the end. With --replaced-log FILE, every replaced slot-frame is also written there,
// summed per wall-clock second, room and slot (the relay soak, tests/server/relay_soak.sh, sets
// them beside the times and rooms of its hostile clients to tell whether those caused any).
// With --delay-log FILE, the largest relay delay and generator lateness of each second (when a
// stall happened, and whose it was).
// A run "sustains" R when every room played, p99 <= --goal-us and nothing
// was replaced. The generator's own lateness (how late it fired ticks) is reported too: a run
// whose generator fell behind measures the generator, not the server.
//
// With --echo build/bench/udp_echo, each server run is paired with a run of the bare UDP echo
// (one syscall per datagram), pinned and niced as the server and loaded at the UDP datagram rate
// the server saw: the ratio of their CPU times is the "server / echo" figure of
// docs/performance.md ("Density"), measured in the same run on the same machine. With
// --echo-batch N as well, the same echo batched (udp_echo --batch N: recvmmsg / sendmmsg, the
// floor of any relay that sends as many datagrams as it receives) at the same rate in the same
// run, the two echoes' order alternating run by run: server / batched echo and batched echo /
// echo are reported beside server / echo, with each process's datagrams in and out per relayed
// input (the server's ENet pings and acknowledgements are datagrams the echo is loaded with too).
// --echo-pass-us P runs the batched echo in passes, as the server's --pass-interval-us P (match
// them). The ratios' medians leave out runs that replaced inputs or whose echo fell behind.
//
// A benchmark, not a test: run by hand (docs/performance.md, "Relay server"), e.g.
//   build/bench/relay_bench --server build/server/lockroll-server --rooms 100,250,500,1000,1500
// Loopback only: the server listens on 127.0.0.1.
#include <CLI/CLI.hpp>
#include <arpa/inet.h>
#include <enet/enet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bench/median.h"
#include "rollback/relay_messages.h"

namespace {

using namespace lockroll::rollback;
using Clock = std::chrono::steady_clock;

std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch()).count());
}

constexpr int kPlayers = 2;
constexpr std::size_t kInputSize = 3;
constexpr int kTickRate = 60;
constexpr std::uint64_t kPeriodUs = 1000000 / kTickRate;
constexpr std::uint32_t kRing = 1024;           // frames of send times kept per room
constexpr std::uint32_t kMaxResend = 8;         // unacknowledged own inputs carried per message
// A replaced input is the generator's own doing when it left 100 ms or more behind its tick (of
// the ~167 ms a bot's input has before the server's deadline: input delay 2 + deadline 8 ticks),
// or had not left at all when its frame was confirmed.
constexpr std::uint64_t kGeneratorLateUs = 100'000;

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

// The replaced slot-frames of the measurement window, summed per wall-clock second (the
// system clock: the soak script stamps its hostile clients with `date`), room and slot:
//   time_ms,run,room,slot,frames,generator_late
// time_ms the second's start (ms since the epoch), room the index 0..R-1, frames the slot's
// replaced frames confirmed in that second, generator_late how many of them were the generator's
// own lateness (kGeneratorLateUs: sent that far behind their tick, or not yet sent when
// confirmed): no one else's doing. A second is written once the next one begins, and at the end
// of the run.
// A per-second CSV log: nullptr when path is empty (no log), else the file with its header.
std::FILE* open_log(const std::string& path, const char* header) {
    if (path.empty()) return nullptr;
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + path);
    std::fprintf(f, "%s\n", header);
    return f;
}

long long wall_second_ms() {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    return ms / 1000 * 1000;
}

class ReplacedLog {
public:
    explicit ReplacedLog(const std::string& path) : f_(open_log(path, "time_ms,run,room,slot,frames,generator_late")) {}
    ~ReplacedLog() {
        if (!f_) return;
        flush();
        std::fclose(f_);
    }
    ReplacedLog(const ReplacedLog&) = delete;
    ReplacedLog& operator=(const ReplacedLog&) = delete;

    void begin_run(int run) {
        flush();
        run_ = run;
    }
    void note(int room, int slot, bool generator_late) {
        if (!f_) return;
        const long long second = wall_second_ms();
        if (second != second_) flush();
        second_ = second;
        auto& [frames, late] = counts_[{room, slot}];
        ++frames;
        late += generator_late ? 1 : 0;
    }
    void flush() {
        if (!f_) return;
        for (const auto& [key, n] : counts_)
            std::fprintf(f_, "%lld,%d,%d,%d,%u,%u\n", second_, run_, key.first, key.second, n.first, n.second);
        counts_.clear();
        std::fflush(f_);
    }

private:
    std::FILE* f_ = nullptr;
    int run_ = 0;
    long long second_ = 0;
    std::map<std::pair<int, int>, std::pair<std::uint32_t, std::uint32_t>> counts_;
};

// The measurement window's relay delay and generator lateness, per wall-clock second (when a
// stall happened, not only how long the worst was: tells a stall of the server, whose delay
// rises while the generator keeps time, from one of the generator):
//   time_ms,samples,delay_max_us,late_max_us
class DelayLog {
public:
    explicit DelayLog(const std::string& path) : f_(open_log(path, "time_ms,samples,delay_max_us,late_max_us"), &std::fclose) {}
    ~DelayLog() {
        if (f_) flush();
    }
    DelayLog(const DelayLog&) = delete;
    DelayLog& operator=(const DelayLog&) = delete;

    void delay(std::uint32_t us) {
        if (!f_) return;
        roll();
        ++samples_;
        delay_max_ = std::max(delay_max_, us);
    }
    void late(std::uint32_t us) {
        if (!f_) return;
        roll();
        late_max_ = std::max(late_max_, us);
    }

private:
    void roll() {
        const long long second = wall_second_ms();
        if (second != second_) flush();
        second_ = second;
    }
    void flush() {
        if (second_ && (samples_ || late_max_)) std::fprintf(f_.get(), "%lld,%u,%u,%u\n", second_, samples_, delay_max_, late_max_);
        samples_ = delay_max_ = late_max_ = 0;
        std::fflush(f_.get());
    }
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f_;
    long long second_ = 0;
    std::uint32_t samples_ = 0, delay_max_ = 0, late_max_ = 0;
};

struct Client {
    ENetPeer* peer = nullptr;
    int room = 0;
    int slot = 0;
    bool welcomed = false;
    std::uint32_t input_ack = 0;        // the server's: next own input it needs
    std::uint32_t confirmed_next = 0;   // frames [0, this) received
    bool has_clock = false;
    bool connected = false;
    double clock_frame = 0;             // server_frame + subframe at clock_at_us
    std::uint64_t clock_at_us = 0;
};

struct Room {
    std::uint64_t id = 0;
    int host = 0;
    Client* c[kPlayers] = {};
    bool live = false;
    std::uint32_t first_frame = 0;      // first frame this room sent inputs for
    std::uint32_t next_frame = 0;       // next frame to send
    std::array<std::uint64_t, kRing> sent_us{};
    std::array<std::uint32_t, kRing> sent_frame{};  // frame + 1 held in each entry
    std::array<std::uint32_t, kRing> sent_late_us{};  // how far behind its tick the frame's first send fired
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

double percentile(std::vector<std::uint32_t>& v, double p) {
    if (v.empty()) return 0;
    const auto k = static_cast<std::size_t>(std::min<double>(static_cast<double>(v.size() - 1), std::floor(p * static_cast<double>(v.size()))));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

// utime + stime of a process, in seconds (stime alone in *sys_s: the kernel's share).
double process_cpu_s(int pid, double* sys_s = nullptr) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto close = text.rfind(')');
    if (close == std::string::npos) return 0;
    std::istringstream in(text.substr(close + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && in >> field; ++i) {
        if (i == 14) utime = std::stoull(field);
        if (i == 15) stime = std::stoull(field);
    }
    const auto tick = static_cast<double>(sysconf(_SC_CLK_TCK));
    if (sys_s) *sys_s = static_cast<double>(stime) / tick;
    return static_cast<double>(utime + stime) / tick;
}

double rss_mib(int pid) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(f, line);)
        if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0;
}

double loadavg() {
    std::ifstream f("/proc/loadavg");
    double l = 0;
    f >> l;
    return l;
}

// The server's status file: a flat JSON object of numbers (server/server_process.cpp).
double status_number(const std::string& path, const std::string& key) {
    std::ifstream f(path);
    std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto at = text.find("\"" + key + "\":");
    if (at == std::string::npos) return -1;
    return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

void pin_to(int cpu) {
    if (cpu < 0) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) std::perror("relay_bench: sched_setaffinity");
}

struct ServerChild {
    int pid = 0;
    std::uint16_t port = 0;
    std::string status_file;
};

// Starts args[0] pinned to the server's CPU at the server's nice, its stderr to log, and waits
// (bounded) for its "ready PORT" line: lockroll-server, or the echo baseline (bench/udp_echo).
ServerChild spawn_ready(const Options& o, std::vector<std::string> args, const std::string& log) {
    ServerChild s;
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    s.pid = fork();
    if (s.pid < 0) throw std::runtime_error("fork failed");
    if (s.pid == 0) {
        pin_to(o.server_cpu);
        if (o.nice != 0) setpriority(PRIO_PROCESS, 0, o.nice);
        dup2(fds[1], 1);
        close(fds[0]);
        close(fds[1]);
        if (FILE* f = std::fopen(log.c_str(), "w")) dup2(fileno(f), 2);
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        execv(argv[0], argv.data());
        std::perror("relay_bench: exec");
        _exit(127);
    }
    close(fds[1]);
    std::string line;
    const std::uint64_t until = now_us() + 10'000'000;
    while (now_us() < until && line.find('\n') == std::string::npos) {
        pollfd p{fds[0], POLLIN, 0};
        if (::poll(&p, 1, 100) <= 0) continue;
        char c[64];
        const ssize_t n = read(fds[0], c, sizeof c);
        if (n <= 0) break;
        line.append(c, static_cast<std::size_t>(n));
    }
    close(fds[0]);
    unsigned port = 0;
    if (std::sscanf(line.c_str(), "ready %u", &port) != 1 || port == 0) {
        kill(s.pid, SIGKILL);
        waitpid(s.pid, nullptr, 0);
        throw std::runtime_error(args[0] + " did not print 'ready PORT' (see " + log + ")");
    }
    s.port = static_cast<std::uint16_t>(port);
    return s;
}

ServerChild start_server(const Options& o, int rooms, const std::string& dir) {
    const std::string status_file = dir + "/status.json";
    std::vector<std::string> args{o.server, "--listen", "127.0.0.1:0", "--max-rooms", std::to_string(rooms + 16),
                                  "--per-address", "4095", "--status-file", status_file, "--log-level", "warn"};
    // Sized as a deployment would size it (docs/deployment.md): ENet walks every connection
    // slot of its host on each pass, used or not.
    if (std::find(o.server_args.begin(), o.server_args.end(), "--max-connections") == o.server_args.end()) {
        args.push_back("--max-connections");
        args.push_back(std::to_string(std::min(4095, 2 * rooms + 64)));
    }
    args.insert(args.end(), o.server_args.begin(), o.server_args.end());
    static int runs = 0;
    ServerChild s = spawn_ready(o, args, dir + "/server-" + std::to_string(rooms) + "-" + std::to_string(runs++) + ".log");
    s.status_file = status_file;
    return s;
}

void stop_server(const ServerChild& s) {
    kill(s.pid, SIGTERM);
    for (int i = 0; i < 100; ++i) {
        if (waitpid(s.pid, nullptr, WNOHANG) == s.pid) return;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    kill(s.pid, SIGKILL);
    waitpid(s.pid, nullptr, 0);
}

class Generator {
public:
    Generator(const Options& o, int rooms, const std::string& host, std::uint16_t port, std::uint64_t run_id, ReplacedLog& log,
              DelayLog& delay_log)
        : o_(o), log_(log), delay_log_(delay_log), rooms_(static_cast<std::size_t>(rooms)), clients_(static_cast<std::size_t>(rooms) * kPlayers) {
        const int hosts = std::max(1, std::min(o.hosts, rooms));
        std::vector<int> per_host(static_cast<std::size_t>(hosts), 0);
        for (int r = 0; r < rooms; ++r) per_host[static_cast<std::size_t>(r % hosts)] += kPlayers;
        for (int h = 0; h < hosts; ++h) {
            ENetHost* e = enet_host_create(nullptr, static_cast<std::size_t>(per_host[static_cast<std::size_t>(h)]), 2, 0, 0);
            if (!e) throw std::runtime_error("enet_host_create failed");
            e->duplicatePeers = ENET_PROTOCOL_MAXIMUM_PEER_ID;
            enet_socket_set_option(e->socket, ENET_SOCKOPT_RCVBUF, 1 << 20);
            hosts_.push_back(e);
        }
        if (enet_address_set_host(&address_, host.c_str()) != 0) throw std::runtime_error("cannot resolve " + host);
        address_.port = port;
        for (int r = 0; r < rooms; ++r) {
            Room& room = rooms_[static_cast<std::size_t>(r)];
            room.id = (run_id << 24) | static_cast<std::uint64_t>(r);
            room.host = r % hosts;
            for (int s = 0; s < kPlayers; ++s) {
                Client& c = clients_[static_cast<std::size_t>(r * kPlayers + s)];
                c.room = r;
                c.slot = s;
                room.c[s] = &c;
            }
        }
    }

    // Rooms connect at a bounded rate (a real fleet's matches do not all begin in one
    // millisecond, and a burst of thousands of handshakes measures the burst, not the relay).
    void connect_more(std::uint64_t now, std::uint64_t start) {
        const auto due = std::min<std::size_t>(rooms_.size(), static_cast<std::size_t>(static_cast<double>(now - start) / 1e6 * o_.ramp_rooms_per_s) + 1);
        for (; connected_rooms_ < due; ++connected_rooms_) {
            Room& room = rooms_[connected_rooms_];
            for (auto* c : room.c) {
                c->peer = enet_host_connect(hosts_[static_cast<std::size_t>(room.host)], &address_, 2, 0);
                if (!c->peer) throw std::runtime_error("enet_host_connect failed");
                c->peer->data = c;
            }
        }
    }
    ~Generator() {
        for (auto& c : clients_)
            if (c.peer) enet_peer_disconnect_now(c.peer, 0);
        for (auto* h : hosts_) {
            enet_host_flush(h);
            enet_host_destroy(h);
        }
    }

    // Runs until every room is live and warm, then measures for o.seconds.
    RunResult run(const ServerChild& server) {
        RunResult res;
        res.rooms = static_cast<int>(rooms_.size());
        const std::uint64_t start = now_us();
        const std::uint64_t ramp_limit = start + 30'000'000;
        const int hosts = static_cast<int>(hosts_.size());
        std::vector<std::uint64_t> next_fire(static_cast<std::size_t>(hosts));
        for (int h = 0; h < hosts; ++h) next_fire[static_cast<std::size_t>(h)] = start + kPeriodUs * static_cast<std::uint64_t>(h) / static_cast<std::uint64_t>(hosts);
        last_service_.assign(static_cast<std::size_t>(hosts), 0);
        // One epoll set over every host's socket: a wait costs what is ready, not what is
        // watched (ppoll over 64 sockets was a quarter of the generator's CPU at 500 rooms).
        const int ep = epoll_create1(EPOLL_CLOEXEC);
        if (ep < 0) throw std::runtime_error("epoll_create1 failed");
        struct EpollFd {
            int fd;
            ~EpollFd() { close(fd); }
        } ep_guard{ep};
        for (int h = 0; h < hosts; ++h) {
            epoll_event ev{};
            ev.events = EPOLLIN;
            ev.data.u32 = static_cast<std::uint32_t>(h);
            if (epoll_ctl(ep, EPOLL_CTL_ADD, static_cast<int>(hosts_[static_cast<std::size_t>(h)]->socket), &ev) != 0)
                throw std::runtime_error("epoll_ctl failed");
        }
        std::vector<epoll_event> ready_events(static_cast<std::size_t>(hosts));
        std::vector<char> readable(static_cast<std::size_t>(hosts), 0);
        std::uint64_t window_start = 0, window_end = 0;
        double cpu0 = 0, sys0 = 0, gen_cpu0 = 0, in0 = 0, out0 = 0, up0 = 0;
        std::uint64_t udp_sent0 = 0, udp_recv0 = 0;
        late_.clear();
        for (;;) {
            const std::uint64_t now = now_us();
            connect_more(now, start);
            // Ticks due: each host's rooms send their inputs, then one flush.
            for (int h = 0; h < hosts; ++h) {
                auto& nf = next_fire[static_cast<std::size_t>(h)];
                while (now >= nf) {
                    if (measuring_) {
                        late_.push_back(static_cast<std::uint32_t>(now - nf));
                        delay_log_.late(late_.back());
                    }
                    fire(h, now, now - nf);
                    nf += kPeriodUs;
                }
            }
            const int live = count_live();
            if (o_.verbose && now >= next_debug_) {
                next_debug_ = now + 1000000;
                int conn = 0, wel = 0, clk = 0;
                for (const auto& c : clients_) {
                    conn += c.connected;
                    wel += c.welcomed;
                    clk += c.has_clock;
                }
                std::fprintf(stderr, "t=%.1f connected %d welcomed %d clock %d live rooms %d disconnects %llu\n",
                             static_cast<double>(now - start) / 1e6, conn, wel, clk, live, static_cast<unsigned long long>(disconnects_));
            }
            if (!window_start && live == static_cast<int>(rooms_.size())) {
                if (!warm_at_) warm_at_ = now + static_cast<std::uint64_t>(o_.warmup * 1e6);
                if (now >= warm_at_) {
                    window_start = now;
                    window_end = now + static_cast<std::uint64_t>(o_.seconds * 1e6);
                    measuring_ = true;
                    cpu0 = server.pid ? process_cpu_s(server.pid, &sys0) : 0;
                    gen_cpu0 = process_cpu_s(getpid());
                    in0 = status_number(server.status_file, "datagrams_in");
                    out0 = status_number(server.status_file, "datagrams_out");
                    up0 = status_number(server.status_file, "uptime_s");
                    udp_sent0 = udp_sent();
                    udp_recv0 = udp_received();
                }
            }
            if (!window_start && now > ramp_limit) {
                res.rooms_live = live;
                std::fprintf(stderr, "relay_bench: only %d of %zu rooms started within 30 s\n", live, rooms_.size());
                return res;
            }
            if (window_start && now >= window_end) {
                const double wall = static_cast<double>(now - window_start) / 1e6;
                res.rooms_live = live;
                double sys1 = 0;
                res.server_cpu = server.pid ? (process_cpu_s(server.pid, &sys1) - cpu0) / wall : 0;
                res.server_sys = server.pid ? (sys1 - sys0) / wall : 0;
                res.server_rss_mib = server.pid ? rss_mib(server.pid) : 0;
                res.client_cpu = (process_cpu_s(getpid()) - gen_cpu0) / wall;
                // The status file is rewritten every second: rates over its own uptime.
                const double up1 = status_number(server.status_file, "uptime_s");
                if (up0 >= 0 && up1 > up0) {
                    res.relay_in_per_s = (status_number(server.status_file, "datagrams_in") - in0) / (up1 - up0);
                    res.relay_out_per_s = (status_number(server.status_file, "datagrams_out") - out0) / (up1 - up0);
                }
                res.udp_in_per_s = static_cast<double>(udp_sent() - udp_sent0) / wall;
                res.udp_out_per_s = static_cast<double>(udp_received() - udp_recv0) / wall;
                res.samples = delays_.size();
                res.p50_us = percentile(delays_, 0.50);
                res.p99_us = percentile(delays_, 0.99);
                res.max_us = delays_.empty() ? 0 : *std::max_element(delays_.begin(), delays_.end());
                res.replaced = replaced_;
                res.unsent = unsent_;
                res.late_p99_us = percentile(late_, 0.99);
                res.late_max_us = late_.empty() ? 0 : *std::max_element(late_.begin(), late_.end());
                res.loadavg = loadavg();
                res.disconnects = disconnects_;
                res.sustained = res.rooms_live == res.rooms && res.disconnects == 0 && res.samples > 0 && res.p99_us <= o_.goal_us &&
                                res.replaced == 0 && res.unsent == 0;
                return res;
            }
            // Wait for traffic until the next tick is due.
            std::uint64_t wake = *std::min_element(next_fire.begin(), next_fire.end());
            const std::uint64_t t = now_us();
            {
                const std::uint64_t wait_us = wake > t ? std::min<std::uint64_t>(wake - t, 999'999) : 0;
                const timespec ts{0, static_cast<long>(wait_us * 1000)};
                std::fill(readable.begin(), readable.end(), 0);
                const int n = epoll_pwait2(ep, ready_events.data(), hosts, &ts, nullptr);
                for (int i = 0; i < n; ++i) readable[ready_events[static_cast<std::size_t>(i)].data.u32] = 1;
            }
            // Readable hosts are serviced at once, the others every few milliseconds (ENet's own
            // timers: connects, pings, acks).
            const std::uint64_t t2 = now_us();
            for (int h = 0; h < hosts; ++h) {
                auto& last = last_service_[static_cast<std::size_t>(h)];
                if (readable[static_cast<std::size_t>(h)] || t2 - last >= 5000) {
                    last = t2;
                    service(h);
                }
            }
        }
    }

private:
    int count_live() const {
        int n = 0;
        for (const auto& r : rooms_) n += r.live ? 1 : 0;
        return n;
    }
    std::uint64_t udp_sent() const {
        std::uint64_t n = 0;
        for (auto* h : hosts_) n += h->totalSentPackets;
        return n;
    }
    std::uint64_t udp_received() const {
        std::uint64_t n = 0;
        for (auto* h : hosts_) n += h->totalReceivedPackets;
        return n;
    }

    void send_hello(Client& c) {
        RelayHello h;
        h.room_id = rooms_[static_cast<std::size_t>(c.room)].id;
        h.scene_checksum = 0x5EED;
        h.players = kPlayers;
        h.input_size = kInputSize;
        h.tick_rate = kTickRate;
        h.slot = static_cast<std::uint8_t>(c.slot);
        h.stamp_us = now_us();
        bytes_.clear();
        encode(h, bytes_);
        enet_peer_send(c.peer, 1, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_RELIABLE));
    }

    // A bot's input: a slow, deterministic pattern (a held direction changes every 30 frames).
    static void bot_input(int room, int slot, std::uint32_t frame, std::uint8_t* out) {
        const std::uint32_t phase = (frame / 30 + static_cast<std::uint32_t>(room * 7 + slot * 3)) % 9;
        out[0] = static_cast<std::uint8_t>(static_cast<int>(phase % 3) - 1);
        out[1] = static_cast<std::uint8_t>(static_cast<int>(phase / 3) - 1);
        out[2] = 0;
    }

    // Queues one RelayInput: the client's own inputs for [first, first + count) (none: a
    // heartbeat) and its acknowledgement.
    void send_input(Client& c, std::uint32_t first, std::uint32_t count, std::uint64_t now) {
        RelayInput& m = input_;
        m.confirmed_ack = c.confirmed_next;
        m.first_frame = first;
        m.frame_count = static_cast<std::uint8_t>(count);
        m.slots = static_cast<std::uint16_t>(1u << c.slot);
        m.inputs.resize(count * kInputSize);
        for (std::uint32_t i = 0; i < count; ++i) bot_input(c.room, c.slot, first + i, &m.inputs[i * kInputSize]);
        m.stamp = static_cast<std::uint16_t>(now / 100);
        m.checksum_count = 0;
        bytes_.clear();
        encode(m, kInputSize, bytes_);
        enet_peer_send(c.peer, 0, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_UNSEQUENCED));
    }

    void fire(int h, std::uint64_t now, std::uint64_t late_us) {
        bool queued = false;
        for (std::size_t r = static_cast<std::size_t>(h); r < rooms_.size(); r += hosts_.size()) {
            Room& room = rooms_[r];
            bool ready = true;
            for (auto* c : room.c) ready = ready && c->peer && c->welcomed && c->has_clock;
            if (!ready) {
                // Waiting for the partner or the first Frames: a welcomed client still says
                // something every tick, as a real one would, or the room drops it as silent.
                for (auto* c : room.c)
                    if (c->peer && c->welcomed) {
                        send_input(*c, 0, 0, now);
                        queued = true;
                    }
                continue;
            }
            if (!room.live) {
                // Join the room clock: the first input is for the frame the clock reaches
                // input_delay frames from now.
                const Client& c = *room.c[0];
                const double clock = c.clock_frame + static_cast<double>(now - c.clock_at_us) / static_cast<double>(kPeriodUs);
                room.first_frame = static_cast<std::uint32_t>(std::ceil(clock)) + static_cast<std::uint32_t>(o_.input_delay);
                room.next_frame = room.first_frame;
                room.live = true;
            }
            const std::uint32_t f = room.next_frame++;
            for (auto* c : room.c) {
                const std::uint32_t first = std::min(f, std::max({c->input_ack, room.first_frame, f + 1 - std::min(f + 1, kMaxResend)}));
                send_input(*c, first, f + 1 - first, now);
                queued = true;
            }
            room.sent_frame[f % kRing] = f + 1;
            room.sent_us[f % kRing] = 0;  // stamped at the flush below
            room.sent_late_us[f % kRing] = static_cast<std::uint32_t>(std::min<std::uint64_t>(late_us, 0xFFFFFFFF));
        }
        if (!queued) return;
        const std::uint64_t t = now_us();
        for (std::size_t r = static_cast<std::size_t>(h); r < rooms_.size(); r += hosts_.size()) {
            Room& room = rooms_[r];
            if (room.live) {
                const std::uint32_t f = room.next_frame - 1;
                if (room.sent_frame[f % kRing] == f + 1 && room.sent_us[f % kRing] == 0) room.sent_us[f % kRing] = t;
            }
        }
        (void)now;
        enet_host_flush(hosts_[static_cast<std::size_t>(h)]);
    }

    void on_frames(Client& c, std::span<const std::uint8_t> d, std::uint64_t at) {
        if (decode(d, kPlayers, kInputSize, frames_) != nullptr) {
            ++bad_;
            return;
        }
        c.input_ack = std::max(c.input_ack, frames_.input_ack);
        c.clock_frame = frames_.server_frame + frames_.server_subframe / 65536.0;
        c.clock_at_us = at;
        c.has_clock = true;
        Room& room = rooms_[static_cast<std::size_t>(c.room)];
        const std::uint32_t end = frames_.first_frame + frames_.frame_count;
        for (std::uint32_t f = std::max(c.confirmed_next, frames_.first_frame); f < end; ++f) {
            if (!measuring_ || !room.live || f < room.first_frame) continue;
            const std::uint32_t i = f - frames_.first_frame;
            const bool unsent = room.sent_frame[f % kRing] != f + 1 || room.sent_us[f % kRing] == 0;
            if (c.slot == 0)
                for (int p = 0; p < kPlayers; ++p)
                    if (frames_.flags[i * kPlayers + static_cast<std::uint32_t>(p)] & kRelayReplaced) {
                        ++replaced_;
                        log_.note(c.room, p, unsent || room.sent_late_us[f % kRing] >= kGeneratorLateUs);
                    }
            if (unsent) {
                if (c.slot == 0) ++unsent_;
                continue;
            }
            delays_.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(at - room.sent_us[f % kRing], 0xFFFFFFFF)));
            delay_log_.delay(delays_.back());
        }
        // Frames arrive in order on loopback; a gap (a lost datagram) is re-sent by the server
        // from our acknowledgement on.
        if (frames_.first_frame <= c.confirmed_next) c.confirmed_next = std::max(c.confirmed_next, end);
    }

    void service(int h) {
        ENetEvent e;
        while (enet_host_service(hosts_[static_cast<std::size_t>(h)], &e, 0) > 0) {
            Client* c = e.peer ? static_cast<Client*>(e.peer->data) : nullptr;
            if (!c) {
                if (e.packet) enet_packet_destroy(e.packet);
                continue;
            }
            switch (e.type) {
                case ENET_EVENT_TYPE_CONNECT:
                    enet_peer_throttle_configure(e.peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
                    c->connected = true;
                    send_hello(*c);
                    break;
                case ENET_EVENT_TYPE_DISCONNECT:
                    ++disconnects_;
                    c->peer = nullptr;
                    break;
                case ENET_EVENT_TYPE_RECEIVE: {
                    const std::uint64_t at = now_us();
                    const std::span<const std::uint8_t> d(e.packet->data, e.packet->dataLength);
                    const auto kind = peek_relay_kind(d);
                    if (kind == RelayKind::Frames) on_frames(*c, d, at);
                    else if (kind == RelayKind::Welcome) {
                        if (decode(d, welcome_) == nullptr && welcome_.refusal == RelayRefusal::None) c->welcomed = true;
                        else
                            std::fprintf(stderr, "relay_bench: room %d slot %d refused: %s\n", c->room, c->slot,
                                         relay_refusal_name(welcome_.refusal));
                    }
                    enet_packet_destroy(e.packet);
                    break;
                }
                default: break;
            }
        }
    }

    const Options& o_;
    ReplacedLog& log_;
    DelayLog& delay_log_;
    ENetAddress address_{};
    std::size_t connected_rooms_ = 0;
    std::vector<Room> rooms_;
    std::vector<Client> clients_;
    std::vector<ENetHost*> hosts_;
    std::vector<std::uint8_t> bytes_;
    RelayInput input_;
    RelayFrames frames_;
    RelayWelcome welcome_;
    std::vector<std::uint32_t> delays_, late_;
    std::vector<std::uint64_t> last_service_;
    std::uint64_t replaced_ = 0, unsent_ = 0, bad_ = 0, disconnects_ = 0, warm_at_ = 0;
    bool measuring_ = false;
    std::uint64_t next_debug_ = 0;
};

// The echo baseline's run, paired with a server run: bench/udp_echo (pinned and niced as the
// server; with batch > 0, udp_echo --batch batch) loaded at rate UDP datagrams a second, sent as the generator sends (o.hosts sockets,
// each firing once per tick at its own phase of the tick, the datagrams of a fire in one
// sendmmsg: the generator's cost is not what is measured), its replies drained. Its CPU
// (utime + stime) over o.seconds after one second of warm-up.
EchoResult run_echo(const Options& o, double rate, int batch, const std::string& dir) {
    static int runs = 0;
    std::vector<std::string> args{o.echo};
    if (batch > 0) args.insert(args.end(), {"--batch", std::to_string(batch)});
    if (batch > 0 && o.echo_pass_us > 0) args.insert(args.end(), {"--pass-us", std::to_string(o.echo_pass_us)});
    const std::string log = dir + "/echo-" + std::to_string(runs++) + ".log";
    const ServerChild echo = spawn_ready(o, args, log);
    EchoResult res;
    const int hosts = std::max(1, o.hosts);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(echo.port);
    const int ep = epoll_create1(EPOLL_CLOEXEC);
    std::vector<int> fds;
    for (int h = 0; h < hosts; ++h) {
        const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK, 0);
        const int big = 1 << 20;
        setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.u32 = static_cast<std::uint32_t>(h);
        epoll_ctl(ep, EPOLL_CTL_ADD, fd, &ev);
        fds.push_back(fd);
    }
    std::array<std::uint8_t, 40> payload{};  // about a relay input with ENet's headers
    std::vector<iovec> iov(4096, iovec{payload.data(), payload.size()});
    std::vector<mmsghdr> out(4096), in(256);
    std::vector<std::array<std::uint8_t, 64>> in_bytes(in.size());
    std::vector<iovec> in_iov(in.size());
    const double per_fire = rate / kTickRate / hosts;
    std::vector<double> owed(static_cast<std::size_t>(hosts), 0);
    const std::uint64_t start = now_us(), window_start = start + 1'000'000;
    const std::uint64_t window_end = window_start + static_cast<std::uint64_t>(o.seconds * 1e6);
    std::vector<std::uint64_t> next_fire(static_cast<std::size_t>(hosts));
    for (int h = 0; h < hosts; ++h) next_fire[static_cast<std::size_t>(h)] = start + kPeriodUs * static_cast<std::uint64_t>(h) / static_cast<std::uint64_t>(hosts);
    std::uint64_t sent = 0, received = 0, sent0 = 0, received0 = 0;
    double cpu0 = 0, sys0 = 0;
    bool measuring = false;
    std::vector<epoll_event> ready(static_cast<std::size_t>(hosts));
    for (;;) {
        const std::uint64_t now = now_us();
        if (!measuring && now >= window_start) {
            measuring = true;
            cpu0 = process_cpu_s(echo.pid, &sys0);
            sent0 = sent;
            received0 = received;
        }
        if (now >= window_end) break;
        for (int h = 0; h < hosts; ++h) {
            auto& nf = next_fire[static_cast<std::size_t>(h)];
            while (now >= nf) {
                owed[static_cast<std::size_t>(h)] += per_fire;
                const auto n = std::min<std::size_t>(out.size(), static_cast<std::size_t>(owed[static_cast<std::size_t>(h)]));
                owed[static_cast<std::size_t>(h)] -= static_cast<double>(n);
                for (std::size_t i = 0; i < n; ++i) {
                    out[i].msg_hdr = {};
                    out[i].msg_hdr.msg_name = &to;
                    out[i].msg_hdr.msg_namelen = sizeof to;
                    out[i].msg_hdr.msg_iov = &iov[i];
                    out[i].msg_hdr.msg_iovlen = 1;
                }
                for (std::size_t at = 0; at < n;) {
                    const int k = sendmmsg(fds[static_cast<std::size_t>(h)], &out[at], static_cast<unsigned>(n - at), 0);
                    if (k <= 0) break;  // the echo's buffer is full: what was not sent is lost, as UDP
                    at += static_cast<std::size_t>(k);
                    sent += static_cast<std::uint64_t>(k);
                }
                nf += kPeriodUs;
            }
        }
        const std::uint64_t wake = *std::min_element(next_fire.begin(), next_fire.end());
        const std::uint64_t t = now_us();
        const std::uint64_t wait_us = wake > t ? std::min<std::uint64_t>(wake - t, 999'999) : 0;
        const timespec ts{0, static_cast<long>(wait_us * 1000)};
        const int n = epoll_pwait2(ep, ready.data(), hosts, &ts, nullptr);
        for (int i = 0; i < n; ++i) {
            const int fd = fds[ready[static_cast<std::size_t>(i)].data.u32];
            for (;;) {
                for (std::size_t j = 0; j < in.size(); ++j) {
                    in_iov[j] = {in_bytes[j].data(), in_bytes[j].size()};
                    in[j].msg_hdr = {};
                    in[j].msg_hdr.msg_iov = &in_iov[j];
                    in[j].msg_hdr.msg_iovlen = 1;
                }
                const int k = recvmmsg(fd, in.data(), static_cast<unsigned>(in.size()), MSG_DONTWAIT, nullptr);
                if (k <= 0) break;
                received += static_cast<std::uint64_t>(k);
            }
        }
    }
    const double wall = static_cast<double>(now_us() - window_start) / 1e6;
    double sys1 = 0;
    res.cpu = (process_cpu_s(echo.pid, &sys1) - cpu0) / wall;
    res.sys = (sys1 - sys0) / wall;
    res.in_per_s = static_cast<double>(sent - sent0) / wall;
    res.out_per_s = static_cast<double>(received - received0) / wall;
    stop_server(echo);
    // Its syscalls per datagram (udp_echo's last line on stderr, written as it exits).
    std::ifstream f(log);
    for (std::string line; std::getline(f, line);) {
        unsigned long long d_in = 0, d_out = 0, receives = 0, sends = 0;
        if (std::sscanf(line.c_str(), "udp_echo: %llu datagrams in, %llu echoed, %llu receive calls, %llu send calls", &d_in, &d_out,
                        &receives, &sends) == 4 && d_in > 0) {
            res.receive_calls = static_cast<double>(receives) / static_cast<double>(d_in);
            res.send_calls = static_cast<double>(sends) / static_cast<double>(d_in);
        }
    }
    for (int fd : fds) close(fd);
    close(ep);
    return res;
}

double ratio(double a, double b) { return b > 0 ? a / b : 0; }

// An echo run kept up when it was sent at least 99 % of the rate asked and sent back at least
// 99 % of what it was sent: one that fell behind (the machine stalled it, its buffer overflowed)
// spent less CPU on fewer datagrams, and its ratio to the server's would flatter the server.
bool echo_kept_up(const EchoResult& e, double rate) { return e.in_per_s >= 0.99 * rate && e.out_per_s >= 0.99 * e.in_per_s; }

// One echo run's line: its rate, CPU (kernel, user), and the server's CPU over it.
void print_echo(const char* name, const EchoResult& e, const RunResult& r) {
    std::printf("       %s at %.0f datagrams/s in, %.0f out (%.4f out per in; %.3f receive, %.3f send calls per datagram): CPU %.1f%% "
                "(kernel %.1f%%, user %.1f%%); server / %s %.3f, server kernel / %s %.3f\n",
                name, e.in_per_s, e.out_per_s, ratio(e.out_per_s, e.in_per_s), e.receive_calls, e.send_calls, e.cpu * 100, e.sys * 100,
                (e.cpu - e.sys) * 100, name, ratio(r.server_cpu, e.cpu), name, ratio(r.server_sys, e.cpu));
}

using lockroll::bench::median;

}  // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{"relay_bench: R two-player rooms of 60 Hz bot inputs against one lockroll-server on loopback"};
    app.add_option("--server", o.server, "lockroll-server binary to start for each run");
    app.add_option("--connect", o.connect, "127.0.0.1:PORT of a server started by hand (one run per R)");
    app.add_option("--server-pid", o.server_pid, "with --connect: its pid, for CPU and RSS");
    app.add_option("--rooms", o.rooms, "room counts to sweep")->delimiter(',')->capture_default_str();
    app.add_option("--seconds", o.seconds, "measurement window per run")->check(CLI::Range(1.0, 3600.0))->capture_default_str();
    app.add_option("--warmup", o.warmup, "seconds after every room started before measuring")->check(CLI::Range(0.0, 60.0))->capture_default_str();
    app.add_option("--repeat", o.repeat, "runs per room count (medians reported)")->check(CLI::Range(1, 50))->capture_default_str();
    app.add_option("--hosts", o.hosts, "ENet client hosts (tick phases)")->check(CLI::Range(1, 64))->capture_default_str();
    app.add_option("--ramp", o.ramp_rooms_per_s, "rooms connected per second before measuring")->check(CLI::Range(1.0, 100000.0))->capture_default_str();
    app.add_option("--input-delay", o.input_delay, "frames a bot's input leads the room clock")->check(CLI::Range(0, 60))->capture_default_str();
    app.add_option("--server-cpu", o.server_cpu, "CPU the server is pinned to (-1: none)")->capture_default_str();
    app.add_option("--client-cpu", o.client_cpu, "CPU the generator is pinned to (-1: none)")->capture_default_str();
    app.add_option("--nice", o.nice, "nice value of the server and the generator (-20: a shared machine's other jobs yield the core)")
        ->check(CLI::Range(-20, 19))
        ->capture_default_str();
    app.add_option("--goal-us", o.goal_us, "p99 relay delay a sustained run stays within")->capture_default_str();
    app.add_flag("--verbose", o.verbose, "print the ramp's progress every second");
    app.add_option("--csv", o.csv, "append one row per run here");
    app.add_option("--delay-log", o.delay_log, "write the relay delay's and the generator's lateness's maximum per second here (CSV)");
    app.add_option("--replaced-log", o.replaced_log,
                   "write the replaced slot-frames here, per second, room and slot (CSV: time_ms,run,room,slot,frames,generator_late)");
    app.add_option("--server-arg", o.server_args, "extra lockroll-server flag (repeatable)");
    app.add_option("--echo", o.echo,
                   "bench/udp_echo binary: after each server run, the bare echo (one syscall per datagram) at that run's UDP "
                   "datagram rate, its CPU as the baseline of the server's (the ratio's median is reported)");
    app.add_option("--echo-batch", o.echo_batch,
                   "with --echo: also the batched echo (udp_echo --batch N: recvmmsg / sendmmsg of up to N; the server takes 64) "
                   "at the same rate, the two echoes' order alternating run by run (0: not)")
        ->check(CLI::Range(0, 1024))
        ->capture_default_str();
    app.add_option("--echo-pass-us", o.echo_pass_us,
                   "with --echo-batch: the batched echo in passes at most one per P us (udp_echo --pass-us; as the server's "
                   "--pass-interval-us, which it should match; 0: a pass per wake-up)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;  // a bad flag: exit 2, as every lockroll program
    }
    if (o.echo_batch > 0 && o.echo.empty()) {
        std::fprintf(stderr, "relay_bench: --echo-batch needs --echo (the udp_echo binary)\n");
        return 2;
    }
    if (o.echo_pass_us > 0 && o.echo_batch == 0) {
        std::fprintf(stderr, "relay_bench: --echo-pass-us needs --echo-batch (only the batched echo runs in passes)\n");
        return 2;
    }
    if (o.server.empty() == o.connect.empty()) {
        std::fprintf(stderr, "relay_bench: give exactly one of --server and --connect\n");
        return 2;
    }
    for (int r : o.rooms)
        if (r < 1 || r > 2000) {
            std::fprintf(stderr, "relay_bench: --rooms: %d is outside 1..2000 (a process holds at most 4000 connections)\n", r);
            return 2;
        }
    if (enet_initialize() != 0) return 1;
    pin_to(o.client_cpu);
    if (o.nice != 0) {
        if (setpriority(PRIO_PROCESS, 0, o.nice) != 0) std::perror("relay_bench: setpriority");
        // With autogroup scheduling a process's nice ranks it only within its session; the
        // session's own weight is its autogroup's nice (the server child shares the session).
        std::ofstream ag("/proc/self/autogroup");
        if (ag) ag << o.nice << "\n";
    }
    const std::string dir = std::filesystem::temp_directory_path() / ("relay_bench." + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    FILE* csv = o.csv.empty() ? nullptr : std::fopen(o.csv.c_str(), "a");
    ReplacedLog replaced_log(o.replaced_log);
    DelayLog delay_log(o.delay_log);
    int run_number = 0;
    if (csv && std::ftell(csv) == 0)
        std::fprintf(csv, "rooms,run,rooms_live,p50_us,p99_us,max_us,samples,replaced,unsent,relay_in_per_s,relay_out_per_s,"
                          "udp_in_per_s,udp_out_per_s,server_cpu,server_rss_mib,generator_cpu,generator_late_p99_us,loadavg,sustained,"
                          "server_sys,echo_cpu,echo_sys,echo_in_per_s,echo_out_per_s,echo_batch,batched_echo_cpu,batched_echo_sys,"
                          "batched_echo_in_per_s,batched_echo_out_per_s,echo_pass_us,echo_receive_calls,batched_echo_receive_calls\n");
    std::printf("%6s %4s %8s %8s %8s %10s %10s %10s %10s %7s %7s %8s %7s %8s %5s %s\n", "rooms", "run", "p50_us", "p99_us", "max_us",
                "replaced", "relay_in/s", "relay_out/s", "udp_in/s", "srv_cpu", "srv_sys", "rss_MiB", "gen_cpu", "late_p99", "load",
                "sustained");
    int best = 0;
    std::uint64_t run_id = static_cast<std::uint64_t>(getpid()) << 8;
    for (int rooms : o.rooms) {
        std::vector<RunResult> runs;
        for (int k = 0; k < o.repeat; ++k) {
            ServerChild server;
            std::string host = "127.0.0.1";
            if (o.server.empty()) {
                const auto colon = o.connect.rfind(':');
                host = o.connect.substr(0, colon);
                server.port = static_cast<std::uint16_t>(std::stoi(o.connect.substr(colon + 1)));
                server.pid = o.server_pid;
            } else {
                server = start_server(o, rooms, dir);
            }
            RunResult r;
            replaced_log.begin_run(run_number++);
            {
                Generator g(o, rooms, host, server.port, ++run_id, replaced_log, delay_log);
                r = g.run(server);
            }
            if (!o.server.empty()) stop_server(server);
            if (!o.echo.empty() && r.udp_in_per_s > 0) {
                // Alternating which echo runs first: neither always gets the machine just after the server.
                const bool batched_first = o.echo_batch > 0 && k % 2 == 1;
                if (batched_first) r.batched = run_echo(o, r.udp_in_per_s, o.echo_batch, dir);
                r.echo = run_echo(o, r.udp_in_per_s, 0, dir);
                if (o.echo_batch > 0 && !batched_first) r.batched = run_echo(o, r.udp_in_per_s, o.echo_batch, dir);
            }
            std::printf("%6d %4d %8.0f %8.0f %8.0f %10llu %10.0f %10.0f %10.0f %6.0f%% %6.0f%% %8.1f %6.0f%% %8.0f %5.1f %s\n", rooms,
                        k, r.p50_us, r.p99_us, r.max_us, static_cast<unsigned long long>(r.replaced + r.unsent), r.relay_in_per_s,
                        r.relay_out_per_s, r.udp_in_per_s, r.server_cpu * 100, r.server_sys * 100, r.server_rss_mib, r.client_cpu * 100,
                        r.late_p99_us, r.loadavg, r.sustained ? "yes" : "no");
            if (!o.echo.empty()) {
                // Per relayed input (the server's relay_in): what the server received and sent, ENet's
                // pings and acknowledgements included; each echo sends what it is sent.
                std::printf("       server per relayed input: %.4f datagrams in, %.4f out (%.4f out per in); CPU kernel %.1f%%, user %.1f%%\n",
                            ratio(r.udp_in_per_s, r.relay_in_per_s), ratio(r.udp_out_per_s, r.relay_in_per_s),
                            ratio(r.udp_out_per_s, r.udp_in_per_s), r.server_sys * 100, (r.server_cpu - r.server_sys) * 100);
                print_echo("echo", r.echo, r);
                if (o.echo_batch > 0) {
                    print_echo("batched echo", r.batched, r);
                    std::printf("       batched echo / echo %.3f\n", ratio(r.batched.cpu, r.echo.cpu));
                }
            }
            std::fflush(stdout);
            if (csv)
                std::fprintf(csv, "%d,%d,%d,%.0f,%.0f,%.0f,%llu,%llu,%llu,%.0f,%.0f,%.0f,%.0f,%.4f,%.1f,%.4f,%.0f,%.2f,%d,%.4f,%.4f,%.4f,%.0f,%.0f,%d,%.4f,%.4f,%.0f,%.0f,%d,%.4f,%.4f\n", rooms, k,
                             r.rooms_live, r.p50_us, r.p99_us, r.max_us, static_cast<unsigned long long>(r.samples),
                             static_cast<unsigned long long>(r.replaced), static_cast<unsigned long long>(r.unsent),
                             r.relay_in_per_s, r.relay_out_per_s, r.udp_in_per_s, r.udp_out_per_s, r.server_cpu,
                             r.server_rss_mib, r.client_cpu, r.late_p99_us, r.loadavg, r.sustained ? 1 : 0, r.server_sys,
                             r.echo.cpu, r.echo.sys, r.echo.in_per_s, r.echo.out_per_s, o.echo_batch, r.batched.cpu, r.batched.sys,
                             r.batched.in_per_s, r.batched.out_per_s, o.echo_pass_us, r.echo.receive_calls, r.batched.receive_calls);
            if (r.disconnects) std::fprintf(stderr, "relay_bench: %llu clients disconnected (server logs in %s)\n",
                                            static_cast<unsigned long long>(r.disconnects), dir.c_str());
            runs.push_back(r);
        }
        // Medians of the runs in which every room started: a run that never got its rooms going
        // measured nothing, and its zeros are no figures (it still counts against "sustained").
        std::vector<const RunResult*> started;
        for (const auto& r : runs)
            if (r.rooms_live == rooms && r.samples > 0) started.push_back(&r);
        auto med = [&](auto field) {
            std::vector<double> v;
            for (const RunResult* r : started) v.push_back(field(*r));
            return median(v);
        };
        int sustained = 0;
        for (const auto& r : runs) sustained += r.sustained ? 1 : 0;
        const bool ok = sustained * 2 > static_cast<int>(runs.size());
        if (ok) best = std::max(best, rooms);
        if (started.empty()) {
            std::printf("median %6d rooms: n/a (no run started every room); sustained in %d of %zu runs\n", rooms, sustained,
                        runs.size());
            std::fflush(stdout);
            continue;
        }
        if (started.size() < runs.size())
            std::printf("median %6d rooms over the %zu of %zu runs that started every room (the others measured nothing):\n",
                        rooms, started.size(), runs.size());
        std::printf("median %6d rooms: p50 %.0f us, p99 %.0f us, relay in %.0f/s out %.0f/s, server CPU %.0f%% of a core "
                    "(kernel %.0f%%; %.1f us per room-second), RSS %.1f MiB, replaced %.0f; sustained in %d of %zu runs\n",
                    rooms, med([](const RunResult& r) { return r.p50_us; }), med([](const RunResult& r) { return r.p99_us; }),
                    med([](const RunResult& r) { return r.relay_in_per_s; }), med([](const RunResult& r) { return r.relay_out_per_s; }),
                    med([](const RunResult& r) { return r.server_cpu * 100; }), med([](const RunResult& r) { return r.server_sys * 100; }),
                    med([&](const RunResult& r) { return r.server_cpu * 1e6 / rooms; }),
                    med([](const RunResult& r) { return r.server_rss_mib; }),
                    med([](const RunResult& r) { return static_cast<double>(r.replaced + r.unsent); }), sustained, runs.size());
        // The ratios' medians: runs in which nothing was replaced (the server kept up) and the
        // echoes kept up (echo_kept_up): a stalled run measured the stall.
        std::vector<const RunResult*> paired;
        for (const RunResult* r : started)
            if (r->replaced + r->unsent == 0 && echo_kept_up(r->echo, r->udp_in_per_s) &&
                (o.echo_batch == 0 || echo_kept_up(r->batched, r->udp_in_per_s)))
                paired.push_back(r);
        auto med_paired = [&](auto field) {
            std::vector<double> v;
            for (const RunResult* r : paired) v.push_back(field(*r));
            return median(v);
        };
        if (!o.echo.empty() && paired.size() < started.size())
            std::printf("median %6d rooms: echo ratios over the %zu of %zu runs in which nothing was replaced and every echo kept up\n",
                        rooms, paired.size(), started.size());
        if (!o.echo.empty())
            std::printf("median %6d rooms: server CPU / echo CPU at the same datagram rate %.3f (paired runs), echo CPU %.1f%%"
                        " (kernel %.1f%%), server kernel / echo %.3f\n",
                        rooms, med_paired([](const RunResult& r) { return ratio(r.server_cpu, r.echo.cpu); }),
                        med_paired([](const RunResult& r) { return r.echo.cpu * 100; }),
                        med_paired([](const RunResult& r) { return r.echo.sys * 100; }),
                        med_paired([](const RunResult& r) { return ratio(r.server_sys, r.echo.cpu); }));
        if (o.echo_batch > 0)
            std::printf("median %6d rooms: server / batched echo (--batch %d) %.3f, batched echo / echo %.3f, batched echo CPU %.1f%%"
                        " (kernel %.1f%%), server kernel / batched echo %.3f\n",
                        rooms, o.echo_batch, med_paired([](const RunResult& r) { return ratio(r.server_cpu, r.batched.cpu); }),
                        med_paired([](const RunResult& r) { return ratio(r.batched.cpu, r.echo.cpu); }),
                        med_paired([](const RunResult& r) { return r.batched.cpu * 100; }),
                        med_paired([](const RunResult& r) { return r.batched.sys * 100; }),
                        med_paired([](const RunResult& r) { return ratio(r.server_sys, r.batched.cpu); }));
        std::fflush(stdout);
    }
    std::printf("largest room count sustained (p99 <= %.0f us, nothing replaced, in most runs): %d\n", o.goal_us, best);
    if (csv) std::fclose(csv);
    std::printf("server logs: %s\n", dir.c_str());
    enet_deinitialize();
    return 0;
}
