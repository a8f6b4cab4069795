#include "harness/live_command.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/live/live_plan.h"
#include "harness/live/live_processes.h"
#include "harness/live/live_report.h"
#include "harness/live/outcome_claims.h"
#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/match/match.h"
#include "harness/match/scene_loader.h"
#include "harness/partition_flag.h"
#include "harness/report/plot_script.h"
#include "harness/report/report.h"
#include "harness/run_command.h"
#include "harness/view_command.h"
#include "net/clock.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;

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
    // The same bound as `lockroll peer` and `client` check, here before any process starts.
    if (!(o.finish_timeout > 0 && o.finish_timeout <= 3600)) throw UsageError("--finish-timeout must be 0..3600 s");
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
    at_list(o.restarts, "--restart", p.restarts);
    const auto after_kill = [&](const std::vector<Kill>& later, const std::string& flag) {
        for (const auto& r : later) {
            const auto k = std::find_if(p.kills.begin(), p.kills.end(), [&](const Kill& x) { return x.slot == r.slot; });
            if (k == p.kills.end() || k->frame >= r.frame)
                throw UsageError(flag + " " + std::to_string(r.slot) + "@" + std::to_string(r.frame) +
                                 ": needs an earlier --kill of the same slot");
        }
    };
    after_kill(p.rejoins, "--rejoin");
    after_kill(p.restarts, "--restart");
    for (const auto& r : p.restarts)
        for (const auto& j : p.rejoins)
            if (j.slot == r.slot)
                throw UsageError("--restart " + std::to_string(r.slot) + "@" + std::to_string(r.frame) +
                                 ": the slot also has a --rejoin; one process per slot comes back");
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
            RunResult r = live_run_result(p, m, dir, recs, delay);
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
    cmd->add_option("--restart", o->restarts,
                    "SLOT@FRAME: restart a --kill'ed slot with its usual arguments (no --join) once slot 0 shows FRAME");
    cmd->add_option("--join", o->joins, "SLOT@FRAME: the slot is absent from frame 0 and its process joins at FRAME");
    cmd->add_option("--spectators", o->spectators, "Spectator processes following the match")->capture_default_str();
    cmd->add_option("--spectate-at", o->spectate_at, "Start the spectators once the match shows this frame (0: at once)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--recoveries", o->recoveries, "Desync recoveries per process (the minority reloads the majority's state)")
        ->capture_default_str();
    cmd->add_option("--disconnect-timeout", o->disconnect_timeout, "Seconds of silence before a slot is dropped")
        ->capture_default_str();
    cmd->add_option("--finish-timeout", o->finish_timeout,
                    "Seconds after the last frame each process waits for every peer to confirm it (also how long a "
                    "partitioned process waits for healing past the match's end)")
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
