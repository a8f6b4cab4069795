#include "harness/live/live_processes.h"

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>

#include "harness/live/child_process.h"
#include "harness/live/free_ports.h"
#include "harness/live/process_output.h"
#include "net/clock.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;

std::string self_exe() {
    std::error_code ec;
    const fs::path p = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw std::runtime_error("cannot find the lockroll executable (/proc/self/exe)");
    return p.string();
}

// The relay server of a relay run: started first, stopped (drained) last.
struct RelayServerRun {
    std::unique_ptr<ChildProcess> process;
    std::uint16_t port = 0;
    fs::path status;
};

RelayServerRun start_relay_server(const LivePlan& p, const std::string& exe, const fs::path& dir, std::uint16_t port) {
    RelayServerRun s;
    s.port = port;
    s.status = dir / "server-status.json";
    s.process = std::make_unique<ChildProcess>(
        std::vector<std::string>{exe, "server", "--listen", "127.0.0.1:" + std::to_string(port), "--status-file", s.status.string(),
                                 "--max-spectators", std::to_string(std::max(1, p.o.spectators)), "--log-level", p.o.log_level},
        (dir / "server.log").string(), true);
    const std::uint64_t until = net::now_us() + 10000000;
    for (;;) {
        for (const auto& line : s.process->read_lines())
            if (line.rfind("ready ", 0) == 0) return s;
        if (!s.process->running()) throw std::runtime_error("the relay server exited at start; see " + (dir / "server.log").string());
        if (net::now_us() > until) throw std::runtime_error("the relay server did not start within 10 s");
        ::usleep(5000);
    }
}

}  // namespace

std::vector<ProcessRecord> run_processes(const LivePlan& p, Mode mode, const fs::path& dir, int input_delay, bool relay,
                                         json* server) {
    const LiveOptions& o = p.o;
    const std::string exe = self_exe();
    const int n = o.players, ids = n + o.spectators;
    // [0, ids): peers and spectators, [ids, ids + n): proxies, then the relay server's.
    const auto ports = free_loopback_ports(n + ids + 1);
    const auto port = [&](int k) { return ports[static_cast<std::size_t>(k)]; };
    const auto front = [&](int k) { return p.proxied ? port(ids + k) : port(k); };
    fs::create_directories(dir);
    RelayServerRun relay_server;
    if (relay) relay_server = start_relay_server(p, exe, dir, port(n + ids));
    // Where a client's traffic goes: to its proxy in front of the server, or to the server.
    const auto relay_front = [&](int k) { return p.proxied && k < n ? port(ids + k) : relay_server.port; };

    std::vector<std::unique_ptr<ChildProcess>> proxies;
    if (p.proxied) {
        // Frame 0 of --partition for every proxy: the run's start, read once (the monotonic
        // clock is the same in every process on the machine).
        const std::uint64_t epoch = net::now_us();
        for (int k = 0; k < n; ++k) {
            std::vector<std::string> args{exe, "proxy", "--listen", "127.0.0.1:" + std::to_string(front(k)), "--to",
                                          "127.0.0.1:" + std::to_string(relay ? relay_server.port : port(k)), "--latency", num(o.latency), "--jitter",
                                          num(o.jitter), "--loss", num(o.loss), "--burst", num(o.burst), "--duplicate",
                                          num(o.duplicate), "--reorder", num(o.reorder), "--seed",
                                          std::to_string(o.seed * 1000 + static_cast<std::uint64_t>(k))};
            // Proxy k stands in front of slot k; its clients are the other players, known by the
            // port they listen and send on (spectators have no slot and are never cut).
            if (!relay && !o.partitions.empty()) {
                args.insert(args.end(), {"--players", std::to_string(n), "--tick-rate", std::to_string(o.tick_rate), "--slot",
                                         std::to_string(k), "--epoch-us", std::to_string(epoch)});
                for (int j = 0; j < n; ++j)
                    if (j != k) args.insert(args.end(), {"--client-slot", std::to_string(j) + "=127.0.0.1:" + std::to_string(port(j))});
                for (const auto& v : o.partitions) args.insert(args.end(), {"--partition", v});
            }
            proxies.push_back(std::make_unique<ChildProcess>(args, (dir / ("proxy" + std::to_string(k) + ".log")).string(), true));
        }
        // Wait (bounded) for every proxy to say it is listening.
        std::vector<bool> ready(static_cast<std::size_t>(n), false);
        const std::uint64_t until = net::now_us() + 10000000;
        while (std::count(ready.begin(), ready.end(), true) < n) {
            for (int k = 0; k < n; ++k) {
                for (const auto& line : proxies[static_cast<std::size_t>(k)]->read_lines())
                    if (line.find("listening") != std::string::npos) ready[static_cast<std::size_t>(k)] = true;
                if (!proxies[static_cast<std::size_t>(k)]->running())
                    throw std::runtime_error("proxy " + std::to_string(k) + " exited at start; see " +
                                             (dir / ("proxy" + std::to_string(k) + ".log")).string());
            }
            if (net::now_us() > until) throw std::runtime_error("the proxies did not start within 10 s");
            ::usleep(5000);
        }
    }

    // What to start, and when.
    std::vector<ProcessRecord> recs;
    for (int k = 0; k < n; ++k) {
        ProcessRecord r;
        r.slot = k;
        r.name = "p" + std::to_string(k);
        for (const auto& j : p.joins)
            if (j.slot == k) {
                r.joiner = true;
                r.after_frame = j.frame;
            }
        recs.push_back(r);
    }
    const int reference = [&] {  // the lowest slot that plays from frame 0: its progress is the clock
        for (int k = 0; k < n; ++k)
            if (!recs[static_cast<std::size_t>(k)].joiner) return k;
        return 0;
    }();
    for (auto& r : recs)
        if (r.joiner) r.after_slot = reference;
    // A rejoin is started with --join; a restart with its usual arguments, as a crashed game is
    // relaunched (the others refuse it as dropped and it rejoins by snapshot on its own).
    const auto comes_back = [&](const Kill& rj, bool restart) {
        ProcessRecord r;
        r.slot = rj.slot;
        r.joiner = true;
        r.restart = restart;
        r.name = "p";  // (+= only: GCC 12's -Wrestrict misfires on "p" + std::string here)
        r.name += std::to_string(rj.slot);
        r.name += restart ? "-restart" : "-rejoin";
        r.after_slot = rj.slot == reference ? (reference + 1) % n : reference;
        r.after_frame = rj.frame;
        r.after_kill_of = rj.slot;
        recs.push_back(r);
    };
    for (const auto& rj : p.rejoins) comes_back(rj, false);
    for (const auto& rj : p.restarts) comes_back(rj, true);
    for (int s = 0; s < o.spectators; ++s) {
        ProcessRecord r;
        r.slot = n + s;
        r.spectator = true;
        r.name = "s" + std::to_string(s);
        if (o.spectate_at > 0) {
            r.after_slot = reference;
            r.after_frame = o.spectate_at;
        }
        recs.push_back(r);
    }
    const auto launch = [&](ProcessRecord& r) {
        std::vector<std::string> args{exe, relay ? "client" : "peer", "--slot", std::to_string(r.slot), "--players", std::to_string(n)};
        const std::string match = std::string("live-") + mode_name(mode) + "-" + std::to_string(o.seed);
        if (relay) {
            args.insert(args.end(), {"--connect", "127.0.0.1:" + std::to_string(relay_front(r.slot)), "--room", match});
            // The relay client adapts its input delay and covers a 300 ms round trip unless told.
            if (o.input_delay != "auto") args.insert(args.end(), {"--input-delay", std::to_string(input_delay)});
            if (o.prediction_given) args.insert(args.end(), {"--prediction", std::to_string(o.prediction)});
        } else {
            args.insert(args.end(), {"--listen", "127.0.0.1:" + std::to_string(port(r.slot))});
            for (int j = 0; j < n; ++j)
                if (j != r.slot) args.insert(args.end(), {"--peer", std::to_string(j) + "=127.0.0.1:" + std::to_string(front(j))});
            args.insert(args.end(), {"--input-delay", std::to_string(input_delay), "--prediction", std::to_string(o.prediction),
                                     "--match-id", match, "--spectators", std::to_string(o.spectators), "--disconnect-timeout",
                                     num(o.disconnect_timeout)});
        }
        args.insert(args.end(),
                    {"--scene", o.scene, "--bot", o.bot, "--frames", std::to_string(o.frames), "--tick-rate",
                     std::to_string(o.tick_rate), "--mode", mode_name(mode), "--seed", std::to_string(o.seed), "--log-level", o.log_level,
                     "--progress", "--recoveries", std::to_string(o.recoveries), "--finish-timeout", num(o.finish_timeout),
                     "--out", (dir / r.name).string()});
        for (const auto& j : p.joins) args.insert(args.end(), {"--absent", std::to_string(j.slot)});
        if (r.joiner && !r.restart) args.emplace_back("--join");
        if (r.spectator) args.emplace_back("--spectate");
        if (!r.spectator && !r.joiner) {
            for (const auto& inj : p.injections) args.insert(args.end(), {"--inject-desync", inj});
            // Whichever player serves a snapshot damages its first chunks.
            if (!relay && o.corrupt_snapshot > 0) args.insert(args.end(), {"--corrupt-snapshot", std::to_string(o.corrupt_snapshot)});
            if (!relay && o.truncate_snapshot > 0) args.insert(args.end(), {"--truncate-snapshot", std::to_string(o.truncate_snapshot)});
        }
        if (const auto skew = p.clock_skew_ppm.find(r.slot); skew != p.clock_skew_ppm.end() && !r.spectator)
            args.insert(args.end(), {"--clock-skew-ppm", std::to_string(skew->second)});
        r.started = true;
        return std::make_unique<ChildProcess>(args, (dir / (r.name + ".stderr.log")).string(), true);
    };
    std::vector<std::unique_ptr<ChildProcess>> procs(recs.size());
    const auto progress_of = [&](int slot) {  // the newest process of that slot
        int f = 0;
        for (const auto& r : recs)
            if (r.slot == slot && r.started) f = r.last_progress;
        return f;
    };
    // Killed and reaped: SIGKILL is asynchronous, and until the process is gone its socket
    // still holds the slot's port, which the process that comes back binds again (a rejoin
    // started at once failed with "cannot create a host bound to 127.0.0.1:<port>").
    const auto killed = [&](int slot) {
        for (std::size_t i = 0; i < recs.size(); ++i)
            if (recs[i].slot == slot && recs[i].killed && procs[i] && !procs[i]->running()) return true;
        return false;
    };

    // Ten match lengths (the processes' own run timeout) plus their finish timeout and 45 s of
    // start-up and slack: 60 s over the ten match lengths at the default 15 s finish timeout.
    const std::uint64_t limit_us = static_cast<std::uint64_t>((10.0 * o.frames / o.tick_rate + 45 + o.finish_timeout) * 1e6);
    const std::uint64_t start = net::now_us();
    for (;;) {
        for (std::size_t i = 0; i < recs.size(); ++i) {
            ProcessRecord& r = recs[i];
            if (r.started) continue;
            const bool due = r.after_slot < 0 || (progress_of(r.after_slot) >= r.after_frame &&
                                                   (r.after_kill_of < 0 || killed(r.after_kill_of)));
            if (!due) continue;
            procs[i] = launch(r);
            if (r.joiner)
                std::fprintf(stderr, "[live %s] started %s (%s slot %d)\n", mode_name(mode), r.name.c_str(),
                             r.restart ? "restarts, without --join," : "joins", r.slot);
        }
        std::vector<pollfd> fds;
        for (const auto& c : procs)
            if (c && c->stdout_fd() >= 0) fds.push_back({c->stdout_fd(), POLLIN, 0});
        if (!fds.empty()) ::poll(fds.data(), fds.size(), 20);
        else ::usleep(20000);
        bool any_running = false, any_waiting = false;
        for (std::size_t i = 0; i < recs.size(); ++i) {
            ProcessRecord& r = recs[i];
            if (!procs[i]) {
                any_waiting = true;
                continue;
            }
            ChildProcess& c = *procs[i];
            for (const auto& line : c.read_lines()) {
                unsigned f = 0;
                if (std::sscanf(line.c_str(), "progress %u", &f) == 1) r.last_progress = static_cast<int>(f);
            }
            for (const Kill& kill : p.kills)
                if (kill.slot == r.slot && !r.joiner && !r.spectator && !r.killed && r.last_progress >= kill.frame && c.running()) {
                    c.signal(SIGKILL);
                    r.killed = true;
                    r.killed_at_frame = r.last_progress;
                    r.killed_mono_us = net::now_us();
                    std::fprintf(stderr, "[live %s] killed slot %d at frame %d\n", mode_name(mode), r.slot, r.last_progress);
                }
            if (c.running()) any_running = true;
        }
        if (!any_running && !any_waiting) break;
        if (!any_running && any_waiting) {
            std::fprintf(stderr, "[live %s] every process ended before the late ones could start\n", mode_name(mode));
            break;
        }
        if (net::now_us() - start > limit_us) {
            std::fprintf(stderr, "[live %s] time limit: stopping the remaining processes\n", mode_name(mode));
            for (auto& c : procs)
                if (c) c->stop(2000);
            break;
        }
    }
    for (auto& c : proxies) c->stop(2000);
    if (relay_server.process) {
        relay_server.process->stop(5000);  // SIGTERM: drains (every room has ended), exits
        if (server) *server = json::parse(read_text(relay_server.status), nullptr, false);
    }
    for (std::size_t i = 0; i < recs.size(); ++i) {
        ProcessRecord& r = recs[i];
        if (!procs[i]) continue;
        r.exit_status = *procs[i]->poll_exit();
        if (r.exit_status != 0 && !r.killed) r.failure = failure_line(dir / (r.name + ".stderr.log"));
        const fs::path pd = dir / r.name;
        if (fs::exists(pd / "summary.json")) r.summary = json::parse(read_text(pd / "summary.json"), nullptr, false);
        std::ifstream ev(pd / "events.jsonl");
        for (std::string line; std::getline(ev, line);) {
            json e = json::parse(line, nullptr, false);
            if (!e.is_discarded()) r.events.push_back(e);
        }
    }
    return recs;
}

}  // namespace lockroll::harness
