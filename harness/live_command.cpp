#include "harness/live_command.h"

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "harness/match/atomic_file.h"
#include "harness/live/child_process.h"
#include "harness/live/free_ports.h"
#include "harness/match/cli_error.h"
#include "harness/match/hex.h"
#include "harness/match/match.h"
#include "harness/match/match_recorder.h"
#include "harness/live/outcome_claims.h"
#include "harness/partition_flag.h"
#include "harness/report/plot_script.h"
#include "harness/report/report.h"
#include "harness/run_command.h"
#include "harness/match/scene_loader.h"
#include "harness/view_command.h"
#include "net/clock.h"
#include "sim/world.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;

struct LiveOptions {
    std::string topology = "p2p";
    int players = 2;
    int frames = 720;
    int tick_rate = 60;
    std::string scene = "paper";
    std::string bot = "random";
    double latency = 0, jitter = 0, loss = 0, burst = 0, duplicate = 0, reorder = 0;
    std::uint64_t seed = 1;
    std::string mode = "both";
    std::string input_delay = "auto";
    int prediction = 8;
    std::vector<std::string> kills, rejoins, joins, injections;
    int spectators = 0;
    int spectate_at = 0;  // frame of the first player at which spectators start (0: at once)
    bool view = false;    // also write each mode's view.html
    std::string out = "out/live";
    std::string log_level = "info";
    bool no_virtual = false;
    double disconnect_timeout = 5;
    int recoveries = 0;
    bool prediction_given = false;
    std::vector<std::string> clock_skews;  // SLOT=PPM (fault test)
    std::vector<std::string> partitions;   // --partition values, passed to every proxy
    int corrupt_snapshot = 0, truncate_snapshot = 0;  // fault tests, on every player from frame 0
};

struct Kill {
    int slot = 0;
    int frame = 0;
};

struct LivePlan {
    LiveOptions o;
    std::vector<Mode> modes;
    RunConfig base;                        // the same match for the virtual-time run
    std::map<Mode, int> input_delay;
    std::vector<Kill> kills, rejoins, joins;  // SLOT@FRAME
    std::vector<std::string> injections;  // CLIENT:FRAME:BODY[:FIELD:BIT], for every peer
    std::map<int, int> clock_skew_ppm;    // slot -> ppm, for every process of that slot
    bool proxied = false;
    std::vector<bool> topologies;  // false: peer to peer, true: through the relay server
};

std::pair<int, int> parse_at(const std::string& text, const std::string& flag) {
    const auto at = text.find('@');
    char *e1 = nullptr, *e2 = nullptr;
    const std::string a = text.substr(0, at == std::string::npos ? 0 : at);
    const std::string b = at == std::string::npos ? "" : text.substr(at + 1);
    const long slot = std::strtol(a.c_str(), &e1, 10);
    const long frame = std::strtol(b.c_str(), &e2, 10);
    if (at == std::string::npos || a.empty() || b.empty() || *e1 || *e2 || slot < 0 || frame < 1)
        throw UsageError(flag + " " + text + ": expected SLOT@FRAME (FRAME >= 1)");
    return {static_cast<int>(slot), static_cast<int>(frame)};
}

LivePlan plan(const LiveOptions& o) {
    LivePlan p;
    p.o = o;
    if (o.topology == "p2p" || o.topology == "both") p.topologies.push_back(false);
    if (o.topology == "relay" || o.topology == "both") p.topologies.push_back(true);
    if (p.topologies.empty()) throw UsageError("--topology " + o.topology + ": expected p2p, relay or both");
    if (o.spectators < 0 || o.spectators > 8) throw UsageError("--spectators must be 0..8");
    if (!(o.disconnect_timeout >= 0.5 && o.disconnect_timeout <= 600)) throw UsageError("--disconnect-timeout must be 0.5..600 s");
    if (o.recoveries < 0 || o.recoveries > 100) throw UsageError("--recoveries must be 0..100");
    p.modes = o.mode == "both"       ? std::vector<Mode>{Mode::Lockstep, Mode::Rollback}
              : o.mode == "lockstep" ? std::vector<Mode>{Mode::Lockstep}
                                     : std::vector<Mode>{Mode::Rollback};
    RunConfig& c = p.base;
    try {
        c.scene = load_scene(o.scene);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    c.players = o.players;
    c.frames = o.frames;
    c.tick_rate = o.tick_rate;
    c.prediction = o.prediction;
    c.net = {o.latency, o.jitter, o.loss, o.burst, o.duplicate, o.reorder};
    c.seed = o.seed;
    c.bot = *parse_bot_kind(o.bot);
    c.record_positions = false;
    validate(c);  // players, frames, rates, network: the same limits and messages as `run`
    // The same cuts in the virtual-time run (from the match's start) and in the proxies (from
    // the live run's start, below).
    c.partitions = parse_partitions(o.partitions, o.players, o.tick_rate);
    if (!c.partitions.empty() && o.topology != "p2p")
        throw UsageError("--partition '" + o.partitions.front() +
                         "': peer to peer only (--topology p2p): through the relay server a client's one link is to "
                         "the server, not to the other slots");
    for (Mode m : p.modes) {
        if (o.input_delay == "auto") {
            // The conditions are known exactly here: cover the worst one-way time.
            const double rtt = 2 * o.latency, worst = 2 * (o.latency + o.jitter);
            p.input_delay[m] = auto_input_delay(m, rtt, worst, o.tick_rate);
        } else {
            char* end = nullptr;
            const long v = std::strtol(o.input_delay.c_str(), &end, 10);
            if (o.input_delay.empty() || *end != '\0' || v < 0 || v > 60)
                throw UsageError("--input-delay " + o.input_delay + ": expected 0..60 or auto");
            p.input_delay[m] = static_cast<int>(v);
        }
    }
    const auto at_list = [&](const std::vector<std::string>& texts, const std::string& flag, std::vector<Kill>& out) {
        for (const auto& k : texts) {
            const auto [slot, frame] = parse_at(k, flag);
            if (slot >= o.players || frame > o.frames) throw UsageError(flag + " " + k + ": SLOT must be 0..players-1, FRAME 1..frames");
            for (const auto& other : out)
                if (other.slot == slot) throw UsageError(flag + " " + k + ": slot given twice");
            out.push_back({slot, frame});
        }
    };
    at_list(o.kills, "--kill", p.kills);
    at_list(o.rejoins, "--rejoin", p.rejoins);
    at_list(o.joins, "--join", p.joins);
    for (const auto& r : p.rejoins) {
        const auto k = std::find_if(p.kills.begin(), p.kills.end(), [&](const Kill& x) { return x.slot == r.slot; });
        if (k == p.kills.end() || k->frame >= r.frame)
            throw UsageError("--rejoin " + std::to_string(r.slot) + "@" + std::to_string(r.frame) +
                             ": needs an earlier --kill of the same slot");
    }
    if (static_cast<int>(p.joins.size()) >= o.players) throw UsageError("--join: at least one slot must play from frame 0");
    for (const auto& j : p.joins)
        for (const auto& k : p.kills)
            if (k.slot == j.slot) throw UsageError("--join and --kill of the same slot are not supported together");
    const sim::SceneDesc scene = with_players(c.scene, o.players);
    for (const auto& text : o.injections) {
        // Passed verbatim to every peer; checked here, as the target's session would, so that a
        // bad one stops live before any process starts.
        if (const std::string e = injection_error(scene, o.players, parse_injection(text)); !e.empty())
            throw UsageError("--inject-desync " + text + ": " + e);
        p.injections.push_back(text);
    }
    for (const auto& text : o.clock_skews) {
        const auto eq = text.find('=');
        const std::string a = text.substr(0, eq == std::string::npos ? 0 : eq);
        const std::string b = eq == std::string::npos ? "" : text.substr(eq + 1);
        char *e1 = nullptr, *e2 = nullptr;
        const long slot = std::strtol(a.c_str(), &e1, 10);
        const long ppm = std::strtol(b.c_str(), &e2, 10);
        if (eq == std::string::npos || a.empty() || b.empty() || *e1 || *e2)
            throw UsageError("--clock-skew " + text + ": expected SLOT=PPM");
        if (slot < 0 || slot >= o.players) throw UsageError("--clock-skew " + text + ": SLOT must be 0..players-1");
        if (ppm < -net::Clock::kMaxSkewPpm || ppm > net::Clock::kMaxSkewPpm)
            throw UsageError("--clock-skew " + text + ": PPM must be -500000..500000");
        if (!p.clock_skew_ppm.emplace(static_cast<int>(slot), static_cast<int>(ppm)).second)
            throw UsageError("--clock-skew " + text + ": slot given twice");
    }
    if (o.corrupt_snapshot < 0 || o.corrupt_snapshot > 1000) throw UsageError("--corrupt-snapshot must be 0..1000");
    if ((o.corrupt_snapshot > 0 || o.truncate_snapshot > 0) && o.topology != "p2p")
        throw UsageError("--corrupt-snapshot / --truncate-snapshot: peer to peer only (--topology p2p)");
    if (o.truncate_snapshot < 0 || o.truncate_snapshot > 1000) throw UsageError("--truncate-snapshot must be 0..1000");
    p.proxied = o.latency > 0 || o.jitter > 0 || o.loss > 0 || o.burst > 0 || o.duplicate > 0 || o.reorder > 0 ||
                !c.partitions.empty();
    return p;
}

std::string self_exe() {
    std::error_code ec;
    const fs::path p = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw std::runtime_error("cannot find the lockroll executable (/proc/self/exe)");
    return p.string();
}

std::string num(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

std::string read_text(const fs::path& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

std::vector<std::vector<std::string>> read_csv_rows(const fs::path& p) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream f(p);
    std::string line;
    bool header = true;
    while (std::getline(f, line)) {
        if (header) {
            header = false;
            continue;
        }
        std::vector<std::string> cells;
        std::stringstream s(line);
        std::string cell;
        while (std::getline(s, cell, ',')) cells.push_back(cell);
        rows.push_back(std::move(cells));
    }
    return rows;
}

struct ProcessRecord {
    int slot = 0;                // player slot, or spectator id (>= players)
    bool spectator = false;
    bool joiner = false;         // started with --join (late join or rejoin)
    std::string name;            // output directory under the mode's directory
    int exit_status = -1;
    bool started = false;
    bool killed = false;
    int killed_at_frame = -1;
    std::uint64_t killed_mono_us = 0;
    int last_progress = 0;
    // Start condition: when player `after_slot` has shown `after_frame` (and, for a rejoin,
    // once `after_kill_of` has been killed). -1: at once.
    int after_slot = -1, after_frame = 0, after_kill_of = -1;
    json summary;  // null when the process left none (killed)
    std::vector<json> events;
};

// Runs one mode's processes; returns what each did (players first, by slot; then rejoined
// players and spectators).
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

// Runs one mode's processes; returns what each did (players first, by slot; then rejoined
// players and spectators). relay: every client talks to one `lockroll server` (through its own
// proxy when impaired) instead of to every other peer; *server gets the server's counters.
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
    for (const auto& rj : p.rejoins) {
        ProcessRecord r;
        r.slot = rj.slot;
        r.joiner = true;
        r.name = "p" + std::to_string(rj.slot) + "-rejoin";
        r.after_slot = rj.slot == reference ? (reference + 1) % n : reference;
        r.after_frame = rj.frame;
        r.after_kill_of = rj.slot;
        recs.push_back(r);
    }
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
                     "--progress", "--recoveries", std::to_string(o.recoveries), "--out", (dir / r.name).string()});
        for (const auto& j : p.joins) args.insert(args.end(), {"--absent", std::to_string(j.slot)});
        if (r.joiner) args.emplace_back("--join");
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
    const auto killed = [&](int slot) {
        for (const auto& r : recs)
            if (r.slot == slot && r.killed) return true;
        return false;
    };

    const std::uint64_t limit_us = static_cast<std::uint64_t>(10.0 * o.frames / o.tick_rate * 1e6) + 60000000;
    const std::uint64_t start = net::now_us();
    for (;;) {
        for (std::size_t i = 0; i < recs.size(); ++i) {
            ProcessRecord& r = recs[i];
            if (r.started) continue;
            const bool due = r.after_slot < 0 || (progress_of(r.after_slot) >= r.after_frame &&
                                                   (r.after_kill_of < 0 || killed(r.after_kill_of)));
            if (!due) continue;
            procs[i] = launch(r);
            if (r.joiner) std::fprintf(stderr, "[live %s] started %s (joins slot %d)\n", mode_name(mode), r.name.c_str(), r.slot);
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

// The mode's figures from what its processes wrote: each process's summary.json (session
// counters), samples.json (MatchRecorder's raw samples), frames.csv and positions.csv. Every
// percentile and maximum is computed from the samples; a process that wrote nothing (killed
// on purpose) is named in r.notes and counts in no figure, and a figure no process measured
// stays empty, to be printed "n/a" with the reason in r.unmeasured.
RunResult collect(const LivePlan& p, Mode mode, const fs::path& dir, const std::vector<ProcessRecord>& all, int input_delay) {
    const LiveOptions& o = p.o;
    RunResult r;
    r.mode = mode_name(mode);
    r.scene = p.base.scene.name;
    r.bot = o.bot;
    r.players = o.players;
    r.frames = o.frames;
    r.tick_rate = o.tick_rate;
    r.input_delay = input_delay;
    r.prediction = mode == Mode::Lockstep ? 0 : o.prediction;
    r.seed = o.seed;
    r.latency_ms = o.latency;
    r.jitter_ms = o.jitter;
    r.loss = o.loss;
    r.duplicate = o.duplicate;
    r.reorder = o.reorder;
    r.burst_loss = o.burst;
    r.completed = true;
    const sim::World world(with_players(p.base.scene, o.players));
    const std::size_t bodies = world.dynamic_count();
    r.body_ids.assign(world.dynamic_ids().begin(), world.dynamic_ids().end());
    r.body_player.assign(bodies, -1);
    for (int pl = 0; pl < world.player_count(); ++pl)
        for (std::size_t b = 0; b < bodies; ++b)
            if (r.body_ids[b] == world.player_body(pl)) r.body_player[b] = pl;
    PositionErrorTracker tracker(o.players, bodies, false);
    // Positions of every player slot: frame -> body positions (exact raw Q32.32 columns). A
    // slot's rejoined process adds the frames from its join on.
    std::vector<std::map<std::uint32_t, std::vector<sim::Vec3>>> shown(static_cast<std::size_t>(o.players));
    std::map<std::uint32_t, double> time_s;
    const int reference = [&] {  // the lowest slot playing from frame 0 and not killed: its times are the rows'
        for (const auto& rec : all)
            if (!rec.spectator && !rec.joiner && !rec.killed && rec.started) return rec.slot;
        return 0;
    }();
    std::vector<RecordedSamples> recorded;
    recorded.reserve(all.size());
    for (const ProcessRecord& rec : all) {
        if (!rec.started) continue;
        if (rec.killed) {
            std::string then = "not rejoined";
            for (const auto& later : all)
                if (later.slot == rec.slot && later.joiner && later.started && &later != &rec)
                    then = "rejoined as " + later.name + " (" +
                           (later.summary.is_object() ? later.summary.value("outcome", "?") : std::string("no summary")) + ")";
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): killed by --kill at frame " +
                              std::to_string(rec.killed_at_frame) + ", " + then +
                              "; a killed process leaves no figures, so it counts in none");
            continue;
        }
        const fs::path pd = dir / rec.name;
        const json& s = rec.summary;
        const json samples = fs::exists(pd / "samples.json") ? json::parse(read_text(pd / "samples.json"), nullptr, false) : json();
        if (!s.is_object() || !samples.is_object()) {
            r.completed = false;
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): left no summary (exit status " +
                              std::to_string(rec.exit_status) + "); it counts in no figure");
            continue;
        }
        recorded.push_back(RecordedSamples::from_json(samples));
        const RecordedSamples& m = recorded.back();
        // Said as the process said it: a partition is the network's doing, reported truthfully,
        // and its figures up to the cut count like any other process's.
        if (s.value("outcome", "") == "partitioned")
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): partitioned since frame " +
                              s.value("partitioned_since_frame", json(nullptr)).dump() +
                              " (heard no majority of the match), not completed; its figures count up to then");
        else if (s.contains("partitioned_since_frame"))
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): " + s.value("outcome_detail", "") +
                              "; its figures count up to then");
        if (s.contains("alone_since_frame") && s.value("outcome", "") == "completed")
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): completed alone since frame " +
                              s["alone_since_frame"].dump() + " (the other player was dropped)");
        const bool final_confirmed = s["final_checksum"].is_string();
        if (!final_confirmed || rec.exit_status != 0) r.completed = false;
        r.virtual_seconds = std::max(r.virtual_seconds, s.value("wall_seconds", 0.0));
        if (rec.spectator) continue;  // a spectator confirms (agreement) but plays no frame of its own
        const json& c0 = s["clients"][0];
        ClientResult c;
        c.ticks_per_second = c0.value("ticks_per_second", 0.0);
        c.stall_fraction = c0.value("stall_fraction", 0.0);
        c.frames = c0.value("frames", 0ull);
        c.ticks = c0.value("ticks", 0ull);
        c.stall_ticks = c0.value("stall_ticks", 0ull);
        c.time_sync_waits = c0.value("time_sync_wait_frames", 0ull);
        c.rollbacks = c0.value("rollbacks", 0ull);
        c.resimulated_frames = c0.value("resimulated_frames", 0ull);
        c.max_rollback_depth = c0.value("max_rollback_depth", 0u);
        c.mispredictions = c0.value("mispredictions", 0ull);
        c.bytes_sent = c0.value("bytes_sent", 0ull);
        c.bytes_received = c0.value("bytes_received", 0ull);
        c.packets_sent = c0.value("packets_sent", 0ull);
        c.packets_received = c0.value("packets_received", 0ull);
        c.malformed_packets = c0.value("malformed_packets", 0ull);
        c.desyncs = c0.value("desyncs", 0ull);
        c.final_confirmed = final_confirmed;
        if (final_confirmed) c.final_checksum = parse_hex16(s["final_checksum"].get<std::string>()).value_or(0);
        c.from_start = !rec.joiner;
        r.clients.push_back(c);
        add_client_samples(r, m);
        for (const auto& [peer, ms] : m.rtt_ms) r.rtt.push_back({rec.slot, peer, ms});
        for (const auto& d : s["desync_reports"]) {
            DesyncRecord dr;
            dr.client = d.value("client", rec.slot);
            dr.summary = d.value("summary", "");
            dr.evidence_file = d.value("evidence_file", "");
            dr.detected_frame = d.value("detected_frame", 0u);
            dr.frame = d.value("frame", 0u);
            dr.body = d.value("body", 0u);
            dr.field = d.value("field", "");
            r.desyncs.push_back(dr);
        }
        for (const auto& row : read_csv_rows(pd / "frames.csv")) {
            if (row.size() < 6) continue;
            const auto f = static_cast<std::uint32_t>(std::stoul(row[0]));
            const auto depth = static_cast<std::uint32_t>(std::stoul(row[3]));
            if (depth) tracker.note_rollback(f, depth);
            if (rec.slot == reference && !rec.joiner) {
                time_s[f] = std::stod(row[1]) / 1000.0;
                tracker.set_tick_rate(f, std::stod(row[4]));
            }
        }
        auto& mine = shown[static_cast<std::size_t>(rec.slot)];
        for (const auto& row : read_csv_rows(pd / "positions.csv")) {
            if (row.size() < 9) continue;
            // The mode's positions.csv (what lockroll view reads): every process's shown bodies.
            r.positions_csv += row[0] + "," + std::to_string(rec.slot) + "," + row[2] + "," + row[3] + "," + row[4] + "," +
                               row[5] + "\n";
            auto& v = mine[static_cast<std::uint32_t>(std::stoul(row[0]))];
            v.push_back({sim::Fixed::from_raw(std::stoll(row[6])), sim::Fixed::from_raw(std::stoll(row[7])),
                         sim::Fixed::from_raw(std::stoll(row[8]))});
        }
    }
    // Position error: every frame, between every pair of slots that both showed it. Slot order
    // as the tracker's client index, so the reference slot's time lands on client 0's rows.
    for (std::uint32_t f = 1; f <= static_cast<std::uint32_t>(o.frames); ++f)
        for (std::size_t k = 0; k < shown.size(); ++k)
            if (const auto it = shown[k].find(f); it != shown[k].end() && it->second.size() == bodies)
                tracker.record(static_cast<int>(k), f, time_s.contains(f) ? time_s[f] : 0.0, it->second);
    tracker.finish();
    if (!r.positions_csv.empty()) {
        r.positions_csv.insert(0, "frame,client,body_index,x,y,z\n");
        r.bodies_csv = bodies_csv(world);
    }
    r.position_error = tracker.error();
    r.rows = tracker.rows();
    std::sort(r.rows.begin(), r.rows.end(), [](const FrameRow& a, const FrameRow& b) { return a.frame < b.frame; });
    r.per_body_max_error = tracker.per_body_max();
    r.pair_error = tracker.pair_errors();
    r.body_error = tracker.body_errors();
    // Confirmed-state agreement: every confirmed checksum every process wrote (spectators too).
    std::vector<const RecordedSamples*> confirmers;
    for (const RecordedSamples& m : recorded) confirmers.push_back(&m);
    std::tie(r.confirmed_compared, r.confirmed_mismatches) = confirmed_agreement(confirmers);
    // Remote input latency across processes (one machine: CLOCK_MONOTONIC in every process).
    std::vector<const RecordedSamples*> players;
    for (const RecordedSamples& m : recorded)
        if (m.slot < o.players) players.push_back(&m);
    r.input_latency_remote = remote_input_latency(players);
    Stat rtts = Stat::keeping_samples();
    for (const auto& pr : r.rtt) rtts.merge(pr.rtt_ms);
    if (rtts.count) {
        r.rtt_p50_ms = rtts.percentile(50);
        r.rtt_p95_ms = rtts.percentile(95);
    } else {
        r.unmeasured["measured_rtt"] = "no process measured a round trip";
    }
    for (const char* field : {"input_latency_local", "input_latency_remote", "rtt", "cpu_us_per_tick", "physics_step_us",
                              "position_error", "displayed_vs_confirmed"})
        r.unmeasured[field] = "no process that completed its part measured it";
    return r;
}

// Longest time a surviving process showed no new frame after a kill: gaps between shown frames
// after the kill, and from its last shown frame to its exit when it never finished.
double longest_stall_after(const ProcessRecord& rec, const fs::path& dir, std::uint64_t kill_us) {
    // Wall times in frames.csv count from the first frame shown (the recorder's start).
    double sync_ms = -1, finish_ms = -1;
    for (const auto& e : rec.events) {
        if (e.value("event", "") == "synchronized" && sync_ms < 0) sync_ms = e.value("mono_ms", 0.0);
        if (e.value("event", "") == "finished") finish_ms = e.value("mono_ms", 0.0);
    }
    if (sync_ms < 0) return 0;
    const double kill_ms = static_cast<double>(kill_us) / 1000.0;
    double last = kill_ms, longest = 0;
    for (const auto& row : read_csv_rows(dir / rec.name / "frames.csv")) {
        const double t = sync_ms + std::stod(row[1]);
        if (t < kill_ms) continue;
        longest = std::max(longest, t - last);
        last = t;
    }
    if (finish_ms > last) longest = std::max(longest, finish_ms - last);
    return longest;
}

json live_json(const std::vector<ProcessRecord>& recs, const fs::path& dir) {
    std::uint64_t first_kill = 0;
    for (const auto& r : recs)
        if (r.killed && (!first_kill || r.killed_mono_us < first_kill)) first_kill = r.killed_mono_us;
    json procs = json::array();
    std::vector<std::string> finals;
    for (const auto& r : recs) {
        if (!r.started) continue;
        // The session's agreed slot changes: dropped (frame: inputs held then) and (re)joined
        // (frame: the first frame of the slot's own inputs).
        json disconnects = json::array(), joins = json::array();
        for (const auto& e : r.events) {
            const std::string ev = e.value("event", "");
            if (ev == "disconnected") disconnects.push_back({{"slot", e.value("peer", -1)}, {"frame", e.value("event_frame", 0)}});
            if (ev == "joined") joins.push_back({{"slot", e.value("peer", -1)}, {"frame", e.value("event_frame", 0)}});
        }
        const json& s = r.summary;
        json p = {{"slot", r.slot},
                  {"name", r.name},
                  {"role", r.spectator ? "spectator" : r.joiner ? "joiner" : "player"},
                  {"exit_status", r.exit_status},
                  {"outcome", s.is_object() ? s.value("outcome", "") : (r.killed ? "killed" : "no summary")},
                  {"final_checksum", s.is_object() ? s["final_checksum"] : json(nullptr)},
                  {"frames_shown", s.is_object() ? s.value("shown_frame", 0) : r.last_progress},
                  {"confirmed_frame", s.is_object() ? s.value("confirmed_frame", 0) : 0},
                  {"ticks_per_second", s.is_object() ? s["ticks_per_second"] : json(0)},
                  {"stall_fraction", s.is_object() ? s["stall_fraction"] : json(nullptr)},
                  {"longest_stall_ms", s.is_object() ? s["longest_stall_ms"] : json(nullptr)},
                  {"clock_skew_ppm", s.is_object() ? s.value("clock_skew_ppm", 0) : 0},
                  {"snapshot_chunks_damaged", s.is_object() ? s.value("snapshot_chunks_damaged", 0) : 0},
                  {"outcome_detail", s.is_object() ? s.value("outcome_detail", "") : ""},
                  {"partitioned_since_frame", s.is_object() ? s.value("partitioned_since_frame", json(nullptr)) : json(nullptr)},
                  {"alone_since_frame", s.is_object() ? s.value("alone_since_frame", json(nullptr)) : json(nullptr)},
                  {"killed_at_frame", r.killed ? json(r.killed_at_frame) : json(nullptr)},
                  {"disconnects", disconnects},
                  {"joins", joins},
                  {"longest_stall_after_kill_ms",
                   first_kill && !r.killed && !r.joiner ? json(longest_stall_after(r, dir, first_kill)) : json(nullptr)}};
        if (!r.killed && s.is_object() && s["final_checksum"].is_string()) finals.push_back(s["final_checksum"]);
        procs.push_back(p);
    }
    // A split run (issue 21): the processes cut off from a majority say "partitioned" and exit 1,
    // truthfully, or, if the network healed after the majority dropped them, "failed" (kicked)
    // with the frame they had been partitioned since; that is the network's doing, not a failure
    // of the match or the harness. The run fails only if a process that was neither killed nor on
    // the cut-off side did not complete, or two final checksums differ (overclaims are added by
    // the caller). Every process partitioned (no majority anywhere) is a split with nobody
    // completed, which is not a failure either.
    bool survivors_ok = true;
    int completed = 0, partitioned = 0;
    json partitioned_names = json::array();
    for (const auto& r : recs) {
        const std::string outcome = r.summary.is_object() ? r.summary.value("outcome", "") : "";
        const bool cut_off = outcome == "partitioned" || (outcome == "failed" && r.summary.contains("partitioned_since_frame"));
        if (r.started && !r.killed && cut_off && r.exit_status != 0) {
            ++partitioned;
            partitioned_names.push_back(r.name);
            continue;
        }
        if (r.started && !r.killed && outcome == "completed" && r.exit_status == 0) ++completed;
        if (!r.killed && (!r.started || r.exit_status != 0)) survivors_ok = false;
    }
    const bool equal = !finals.empty() && std::all_of(finals.begin(), finals.end(), [&](const auto& f) { return f == finals[0]; });
    const bool agreed = finals.empty() ? partitioned > 0 : equal;
    return {{"processes", procs},
            {"final_checksums_equal", equal},
            {"survivors_completed", survivors_ok},
            // partitioned: processes on the cut-off side (outcome partitioned, or failed: kicked
            // out of a partition once it healed).
            {"split", {{"completed", completed}, {"partitioned", partitioned}, {"partitioned_processes", partitioned_names}}},
            {"ok", agreed && survivors_ok}};
}

std::string side_by_side(const std::vector<std::pair<std::string, const RunResult*>>& runs) {
    std::ostringstream o;
    o << "| run | ticks/s | stalls | input delay | mean error (m) | max error (m) | rollbacks | CPU us/tick | payload B/s | "
         "mismatches | desyncs | completed |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    char line[512];
    for (const auto& [name, r] : runs) {
        std::snprintf(line, sizeof line, "| %s | %.2f | %.1f %% | %d | %s | %s | %llu | %s | %.0f | %llu | %llu | %s |\n",
                      name.c_str(), r->ticks_per_second(), 100 * r->stall_fraction(), r->input_delay,
                      figure(r->position_error, "%.3g", r->position_error.mean()).c_str(),
                      figure(r->position_error, "%.3g", r->position_error.max).c_str(),
                      static_cast<unsigned long long>(r->rollbacks()), figure(r->cpu_us_per_tick, "%.1f", r->cpu_us_per_tick.mean()).c_str(),
                      r->bytes_sent_per_s(), static_cast<unsigned long long>(r->confirmed_mismatches),
                      static_cast<unsigned long long>(r->desync_count()), r->completed ? "yes" : "NO");
        o << line;
    }
    return o.str();
}

// One row per mode and topology: what the relay costs and gives against the mesh.
std::string topology_table(const std::vector<std::tuple<std::string, const RunResult*, json>>& rows, int frames, int tick_rate) {
    std::ostringstream o;
    o << "| run | ticks/s | stalls | mean error (m) | rollbacks | input latency (ms) | payload B/s per client (sent) | "
         "server payload B/s (in + out) | replaced inputs | completed |\n|---|---|---|---|---|---|---|---|---|---|\n";
    const double seconds = static_cast<double>(frames) / tick_rate;
    char line[600];
    for (const auto& [name, r, extra] : rows) {
        const bool relay = extra.is_object() && extra.contains("server");
        const double server_bps = relay ? static_cast<double>(extra["server"].value("bytes_in", 0ull) +
                                                              extra["server"].value("bytes_out", 0ull)) / seconds
                                        : 0.0;
        std::snprintf(line, sizeof line, "| %s | %.2f | %.1f %% | %s | %llu | %s | %.0f | %s | %s | %s |\n", name.c_str(),
                      r->ticks_per_second(), 100 * r->stall_fraction(),
                      figure(r->position_error, "%.3g", r->position_error.mean()).c_str(),
                      static_cast<unsigned long long>(r->rollbacks()),
                      figure(r->input_latency_local, "%.1f", r->input_latency_local.mean()).c_str(), r->bytes_sent_per_s(),
                      relay ? num(server_bps).c_str() : "-",
                      relay ? std::to_string(extra.value("replaced", 0ull)).c_str() : "-", r->completed ? "yes" : "NO");
        o << line;
    }
    return o.str();
}

int do_live(const LiveOptions& options) {
    const LivePlan p = plan(options);
    const fs::path out(p.o.out);
    fs::create_directories(out);
    std::map<Mode, RunResult> live, virt;
    json modes = json::object();
    bool ok = true;
    std::map<std::string, RunResult> by_name;
    std::vector<std::tuple<std::string, const RunResult*, json>> topo_rows;
    std::map<std::string, json> topo_extra;
    for (const bool relay : p.topologies) {
        // Both modes: also rollback at input delay 0, the like-for-like run of the paper
        // (compare's third column), as real processes too (peer to peer only).
        std::vector<std::pair<std::string, Mode>> runs;
        for (Mode m : p.modes) runs.emplace_back((relay ? "relay-" : "") + std::string(mode_name(m)), m);
        if (p.modes.size() == 2 && !relay) runs.emplace_back("rollback-delay0", Mode::Rollback);
        // The lockstep-against-rollback comparison is of the first topology run.
        const bool primary = relay == p.topologies.front();
        for (const auto& [name, m] : runs) {
            const fs::path dir = out / name;
            const int delay = name == "rollback-delay0" ? 0 : p.input_delay.at(m);
            std::fprintf(stderr, "[live] %s: %d processes%s%s, %d frames\n", name.c_str(), p.o.players,
                         relay ? " through the relay server" : "", p.proxied ? " behind proxies" : "", p.o.frames);
            json server;
            const auto recs = run_processes(p, m, dir, delay, relay, &server);
            RunResult r = collect(p, m, dir, recs, delay);
            if (relay)  // the relay clients chose their own delay (adaptive) and window
                for (const auto& rec : recs)
                    if (!rec.spectator && rec.summary.is_object()) {
                        r.input_delay = rec.summary["input_delay"].value("start", r.input_delay);
                        r.prediction = rec.summary.value("prediction_window", r.prediction);
                        break;
                    }
            write_file_atomic(dir / "summary.json", summary_json(r).dump(2) + "\n");
            write_file_atomic(dir / "frames.csv", frames_csv(r));
            if (!r.positions_csv.empty()) {
                write_file_atomic(dir / "positions.csv", r.positions_csv);
                write_file_atomic(dir / "bodies.csv", r.bodies_csv);
                if (p.o.view) std::printf("written %s\n", write_view(dir).string().c_str());
            }
            json lj = live_json(recs, dir);
            std::vector<std::string> claims;
            for (const auto& rec : recs) {
                if (!rec.started) continue;
                const auto c = overclaims({rec.name, rec.summary, rec.killed, rec.killed_at_frame, rec.exit_status}, p.o.frames);
                claims.insert(claims.end(), c.begin(), c.end());
            }
            if (!claims.empty()) {
                lj["overclaims"] = claims;
                lj["ok"] = false;
                for (const auto& c : claims) std::fprintf(stderr, "[live] %s: %s\n", name.c_str(), c.c_str());
            }
            json extra = json::object();
            if (relay) {
                std::uint64_t replaced = 0;
                for (const auto& rec : recs)
                    if (rec.summary.is_object() && rec.summary.contains("relay"))
                        replaced += rec.summary["relay"].value("own_replaced", 0ull);
                extra = {{"server", server.is_discarded() ? json::object() : server}, {"replaced", replaced}};
                lj["relay_server"] = extra["server"];
                lj["replaced_inputs"] = replaced;
            }
            ok = ok && lj["ok"].get<bool>();
            modes[name] = lj;
            std::printf("real processes, %s", console_summary(r).c_str());
            if (const json& split = lj["split"]; split["partitioned"].get<int>() > 0)
                std::printf("  split        %d completed%s, %d partitioned (%s)\n", split["completed"].get<int>(),
                            split["completed"].get<int>() == 0 ? ""
                            : lj["final_checksums_equal"].get<bool>() ? " on one final"
                                                                      : " on DIFFERENT finals",
                            split["partitioned"].get<int>(), split["partitioned_processes"].dump().c_str());
            if (primary && name == mode_name(m) + std::string()) live.emplace(m, r);
            if (primary && relay && name == "relay-" + std::string(mode_name(m))) live.emplace(m, r);
            topo_extra[name] = extra;
            by_name.emplace(name, std::move(r));
            if (!p.o.no_virtual && !relay && name == mode_name(m)) {
                RunConfig cfg = p.base;
                cfg.mode = m;
                cfg.input_delay = delay;
                RunResult v = run_match(cfg);
                write_run(out / "virtual" / mode_name(m), v);
                virt.emplace(m, std::move(v));
            }
        }
    }
    write_file_atomic(out / "live.json", json{{"modes", modes}, {"ok", ok}}.dump(2) + "\n");

    std::vector<std::pair<std::string, const RunResult*>> table;
    for (Mode m : p.modes) {
        table.emplace_back(std::string(mode_name(m)) + ", real UDP processes", &live.at(m));
        if (virt.contains(m)) table.emplace_back(std::string(mode_name(m)) + ", virtual time (in process)", &virt.at(m));
    }
    std::string report;
    if (p.modes.size() == 2) {
        const std::string plot_error = run_plot_script("plot.py", {"compare", out.string()});
        const std::string note = plot_error.empty()
                                     ? "![error against run time](error_vs_time.png)\n\n![rollback depth](rollback_depth.png)\n\n"
                                       "![tick rate over time](tick_rate.png)\n"
                                     : "Plots were not made: " + plot_error + "\n";
        const RunResult& delay0 = by_name.contains("rollback-delay0") ? by_name.at("rollback-delay0") : live.at(Mode::Rollback);
        write_file_atomic(out / "compare.json", compare_json(live.at(Mode::Lockstep), live.at(Mode::Rollback), delay0).dump(2) + "\n");
        report = compare_markdown(live.at(Mode::Lockstep), live.at(Mode::Rollback), delay0, note);
    } else {
        report = run_markdown(live.at(p.modes.front()), std::string(mode_name(p.modes.front())) + ", real processes");
    }
    report += "\n## Real processes beside virtual time\n\nThe same scene, players, frames, seed, input delay and network "
              "conditions: N `lockroll peer` processes over ENet on 127.0.0.1 (through `lockroll proxy` when impaired), "
              "and the in-process virtual-time match (`lockroll run`).\n\n" +
              side_by_side(table) + "\nPer-process details: live.json, MODE/pK/.\n";
    if (std::find(p.topologies.begin(), p.topologies.end(), true) != p.topologies.end()) {
        for (Mode m : p.modes)
            for (const std::string prefix : {"", "relay-"})
                if (const std::string name = prefix + mode_name(m); by_name.contains(name))
                    topo_rows.emplace_back(name, &by_name.at(name), topo_extra[name]);
        report += "\n## Peer to peer against the relay server\n\nThe same conditions on every client's link (through the "
                  "server, a client's input travels two links). Payload: the session's own bytes, without ENet/UDP/IP "
                  "headers. Server payload: everything the server received and sent, per second of match.\n\n" +
                  topology_table(topo_rows, p.o.frames, p.o.tick_rate);
    }
    write_file_atomic(out / "report.md", report);
    std::printf("written %s/report.md, live.json%s\n", out.c_str(), p.modes.size() == 2 ? ", compare.json" : "");
    std::fflush(stdout);
    return ok ? 0 : 1;
}

}  // namespace

void add_live_command(CLI::App& app) {
    auto o = std::make_shared<LiveOptions>();
    CLI::App* cmd = app.add_subcommand(
        "live", "Real processes: N `lockroll peer` over ENet on loopback behind impairment proxies; DIR/report.md, live.json");
    cmd->add_option("--topology", o->topology, "p2p (every peer talks to every other), relay (every client to one `lockroll server`) or both")
        ->check(CLI::IsMember({"p2p", "relay", "both"}))
        ->capture_default_str();
    cmd->add_option("--players", o->players, "Processes (2..16)")->capture_default_str();
    cmd->add_option("--frames", o->frames, "Frames every process plays")->capture_default_str();
    cmd->add_option("--tick-rate", o->tick_rate, "Ticks per second")->capture_default_str();
    cmd->add_option("--scene", o->scene, "Scene file or shipped scene name")->capture_default_str();
    cmd->add_option("--bot", o->bot, "Input bots: random or chase")->check(CLI::IsMember({"random", "chase"}))->capture_default_str();
    cmd->add_option("--latency", o->latency, "One-way latency, ms (each direction, through the proxies)")->capture_default_str();
    cmd->add_option("--jitter", o->jitter, "Uniform jitter, +- ms per packet")->capture_default_str();
    cmd->add_option("--loss", o->loss, "Packet loss probability 0..1")->capture_default_str();
    cmd->add_option("--burst,--burst-loss", o->burst, "Probability per packet of entering a loss burst 0..1")->capture_default_str();
    cmd->add_option("--duplicate", o->duplicate, "Duplication probability 0..1")->capture_default_str();
    cmd->add_option("--reorder", o->reorder, "Reordering probability 0..1")->capture_default_str();
    cmd->add_option("--seed", o->seed, "Seed for the bots and the proxies")->capture_default_str();
    cmd->add_option("--mode", o->mode, "lockstep, rollback or both")->check(CLI::IsMember({"lockstep", "rollback", "both"}))->capture_default_str();
    cmd->add_option("--input-delay", o->input_delay, "Input delay in frames, or auto (from the latency and jitter asked for)")
        ->capture_default_str();
    cmd->add_option("--prediction", o->prediction, "Prediction window W in rollback mode")->capture_default_str();
    cmd->add_option("--kill", o->kills, "SLOT@FRAME: SIGKILL that process once it shows FRAME (repeatable)");
    cmd->add_option("--rejoin", o->rejoins, "SLOT@FRAME: restart a --kill'ed slot with --join once slot 0 shows FRAME");
    cmd->add_option("--join", o->joins, "SLOT@FRAME: the slot is absent from frame 0 and its process joins at FRAME");
    cmd->add_option("--spectators", o->spectators, "Spectator processes following the match")->capture_default_str();
    cmd->add_option("--spectate-at", o->spectate_at, "Start the spectators once the match shows this frame (0: at once)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--recoveries", o->recoveries, "Desync recoveries per process (the minority reloads the majority's state)")
        ->capture_default_str();
    cmd->add_option("--disconnect-timeout", o->disconnect_timeout, "Seconds of silence before a slot is dropped")
        ->capture_default_str();
    cmd->add_option("--inject-desync", o->injections, "CLIENT:FRAME:BODY[:FIELD:BIT] flip one bit on one process (repeatable)");
    cmd->add_option("--log-level", o->log_level, "Log level of the peer processes")->capture_default_str();
    cmd->add_option("--partition", o->partitions,
                    "SETS@FROM-UNTIL: the proxies drop datagrams between the slot sets from frame FROM until UNTIL, "
                    "frames counted in real time from the run's start at --tick-rate (p2p only; repeatable, or ';')");
    cmd->add_option("--clock-skew", o->clock_skews,
                    "SLOT=PPM: fault test, that slot's clock runs PPM parts per million fast (> 0) or slow (< 0) (repeatable)");
    cmd->add_option("--corrupt-snapshot", o->corrupt_snapshot,
                    "Fault test: every player from frame 0 flips a bit in the first N snapshot chunks it sends")
        ->capture_default_str();
    cmd->add_option("--truncate-snapshot", o->truncate_snapshot,
                    "Fault test: every player from frame 0 drops the last byte of the first N snapshot chunks it sends")
        ->capture_default_str();
    cmd->add_flag("--no-virtual", o->no_virtual, "Skip the in-process virtual-time run beside it");
    cmd->add_flag("--view", o->view, "Also write DIR/MODE/view.html (lockroll view) for every mode run");
    cmd->add_option("--out", o->out, "Output directory")->capture_default_str();
    cmd->callback([o, cmd] {
        o->prediction_given = cmd->count("--prediction") > 0;
        if (do_live(*o) != 0) throw std::runtime_error("live: a process failed or the final checksums differ (see live.json)");
    });
}

}  // namespace lockroll::harness
