#include "harness/run_command.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/cli_validators.h"
#include "harness/match/match.h"
#include "harness/report/output_path.h"
#include "harness/partition_flag.h"
#include "harness/report/plot_script.h"
#include "harness/replay_command.h"
#include "harness/report/report.h"
#include "harness/match/scene_loader.h"
#include "harness/view_command.h"
#include "rollback/world_simulation.h"
#include "sim/world.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;

struct RunOptions {
    std::string scene = "paper";
    std::string mode = "rollback";
    int players = 2;
    int frames = 720;
    int tick_rate = 60;
    std::string input_delay = "auto";
    int prediction = 8;
    int checksum_interval = 1;
    double latency = 0, jitter = 0, loss = 0, duplicate = 0, reorder = 0, burst_loss = 0, drift_ppm = 0;
    std::uint64_t seed = 1;
    std::string bot = "random";
    std::string out = "out/run";
    bool positions = false;
    bool view = false;
    std::string record;
    std::vector<std::string> injections;
    std::vector<std::string> partitions;
};

void add_common(CLI::App* cmd, RunOptions& o, bool with_mode) {
    cmd->add_option("--scene", o.scene, "Scene file or shipped scene name")->capture_default_str();
    if (with_mode) cmd->add_option("--mode", o.mode, "rollback or lockstep")->check(CLI::IsMember({"rollback", "lockstep"}))->capture_default_str();
    cmd->add_option("--players", o.players, "Clients (2..16); player bodies are added when the scene has fewer")
        ->capture_default_str();
    cmd->add_option("--frames", o.frames, "Frames every client simulates")->capture_default_str();
    cmd->add_option("--tick-rate", o.tick_rate, "Ticks per second (also the physics rate)")->capture_default_str();
    cmd->add_option("--input-delay", o.input_delay,
                    "Input delay in frames, auto (from RTT and jitter measured before the match) or adaptive "
                    "(auto, then re-picked every second from the RTT measured during it)")
        ->capture_default_str();
    cmd->add_option("--prediction", o.prediction, "Prediction window W in rollback mode")->capture_default_str();
    cmd->add_option("--checksum-interval", o.checksum_interval, "Compare confirmed checksums every K frames")
        ->capture_default_str();
    cmd->add_option("--latency", o.latency, "One-way latency, ms")->capture_default_str();
    cmd->add_option("--jitter", o.jitter, "Uniform jitter, +- ms per packet")->capture_default_str();
    cmd->add_option("--loss", o.loss, "Packet loss probability 0..1")->capture_default_str();
    cmd->add_option("--burst-loss", o.burst_loss, "Probability per packet of entering a loss burst 0..1")->capture_default_str();
    cmd->add_option("--duplicate", o.duplicate, "Duplication probability 0..1")->capture_default_str();
    cmd->add_option("--reorder", o.reorder, "Reordering probability 0..1")->capture_default_str();
    cmd->add_option("--partition", o.partitions,
                    "SETS@FROM-UNTIL: cut the links between slot sets from frame FROM until UNTIL, e.g. "
                    "0,1/2,3@200-800 (repeatable, or ';' between cuts; unnamed slots keep their links)");
    cmd->add_option("--drift-ppm", o.drift_ppm, "Client clock drift, up to +- this many ppm each")->capture_default_str();
    cmd->add_option("--seed", o.seed, "Seed for the network, clocks and bots")
        ->check(kNonNegativeInteger)
        ->capture_default_str();
    cmd->add_option("--bot", o.bot, "Input bots: random or chase")->check(CLI::IsMember({"random", "chase"}))->capture_default_str();
    cmd->add_option("--out", o.out, "Output directory")->capture_default_str();
    cmd->add_flag("--positions", o.positions, "Also write positions.csv (every body, frame and client)");
    cmd->add_flag("--view", o.view, "Also write view.html (implies --positions; see lockroll view)");
    if (with_mode)
        cmd->add_option("--record", o.record,
                        "Write a replay (confirmed inputs and checksums) to this file; check it with lockroll replay");
    cmd->add_option("--inject-desync", o.injections,
                    "CLIENT:FRAME:BODY[:FIELD:BIT] flip one bit of one body on one client at a frame (repeatable)");
}

RunConfig to_config(const RunOptions& o) {
    check_output_dir("--out", o.out);
    if (!o.record.empty()) check_output_file("--record", o.record);
    RunConfig c;
    try {
        c.scene = load_scene(o.scene);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    c.mode = o.mode == "lockstep" ? Mode::Lockstep : Mode::Rollback;
    c.players = o.players;
    c.frames = o.frames;
    c.tick_rate = o.tick_rate;
    if (o.input_delay == "auto" || o.input_delay == "adaptive") {
        c.input_delay = -1;
        c.adaptive_delay = o.input_delay == "adaptive";
    } else {
        char* end = nullptr;
        const long v = std::strtol(o.input_delay.c_str(), &end, 10);
        if (o.input_delay.empty() || *end != '\0' || v < 0) throw UsageError("--input-delay " + o.input_delay + ": expected a frame count, auto or adaptive");
        c.input_delay = static_cast<int>(v);
    }
    c.prediction = o.prediction;
    c.checksum_interval = o.checksum_interval;
    c.net = {o.latency, o.jitter, o.loss, o.burst_loss, o.duplicate, o.reorder};
    c.seed = o.seed;
    c.bot = *parse_bot_kind(o.bot);
    c.drift_ppm = o.drift_ppm;
    for (const auto& s : o.injections) c.injections.push_back(parse_injection(s));
    c.record_positions = o.positions || o.view;
    c.record_inputs = !o.record.empty();
    c.evidence_dir = (fs::path(o.out) / "desync").string();
    if (::isatty(2))
        c.progress = [tag = std::string(mode_name(c.mode))](int shown, int total) {
            std::fprintf(stderr, "\r[%s] frame %d / %d ", tag.c_str(), shown, total);
            if (shown >= total) std::fprintf(stderr, "\n");
        };
    validate(c);
    // After validate: the partition's slots and frames are read against --players and --tick-rate.
    c.partitions = parse_partitions(o.partitions, c.players, c.tick_rate);
    return c;
}

void do_run(const RunOptions& o) {
    const RunConfig cfg = to_config(o);
    const RunResult r = run_match(cfg);
    write_run(o.out, r);
    if (o.view) write_view(o.out);
    if (!o.record.empty() && r.completed) {
        rollback::Replay replay;
        replay.players = static_cast<std::uint32_t>(r.players);
        replay.input_size = rollback::kWorldInputSize;
        replay.tick_rate = static_cast<std::uint32_t>(r.tick_rate);
        replay.initial_checksum = r.initial_checksum;
        replay.scene_name = o.scene;
        replay.scene_text = scene_text_for_replay(o.scene);
        for (const auto& in : r.confirmed_inputs) replay.inputs.insert(replay.inputs.end(), in.begin(), in.end());
        replay.checksums = r.confirmed_checksums;
        write_replay_file(o.record, replay);
    }
    std::printf("%s", console_summary(r).c_str());
    std::printf("  written      %s/summary.json, frames.csv%s\n", o.out.c_str(), r.positions_csv.empty() ? "" : ", positions.csv");
    std::fflush(stdout);
    if (!r.completed) {
        // Issue 21: a client cut off from a majority at the end never completed; say which.
        const std::string cut_off = partitioned_clients(r);
        throw std::runtime_error("run did not complete: not every client confirmed the last frame" +
                                 (cut_off.empty() ? std::string() : "; partitioned: " + cut_off));
    }
}

void do_compare(const RunOptions& o) {
    RunOptions lo = o, ro = o, r0 = o;
    lo.mode = "lockstep";
    ro.mode = "rollback";
    r0.mode = "rollback";
    r0.input_delay = "0";  // like-for-like with the paper: rollback hiding all latency
    lo.out = (fs::path(o.out) / "lockstep").string();
    ro.out = (fs::path(o.out) / "rollback").string();
    r0.out = (fs::path(o.out) / "rollback-delay0").string();
    const RunConfig lcfg = to_config(lo), rcfg = to_config(ro), r0cfg = to_config(r0);
    const RunResult ls = run_match(lcfg);
    const RunResult rb = run_match(rcfg);
    const RunResult rb0 = rb.input_delay == 0 ? rb : run_match(r0cfg);
    write_run(lo.out, ls);
    write_run(ro.out, rb);
    write_run(r0.out, rb0);
    const std::string plot_error = run_plot_script("plot.py", {"compare", o.out});
    const std::string note = plot_error.empty()
                                 ? "![error against run time](error_vs_time.png)\n\n![rollback depth](rollback_depth.png)\n\n"
                                   "![tick rate over time](tick_rate.png)\n\n![time sync](time_sync.png)\n"
                                 : "Plots were not made: " + plot_error + "\n";
    write_file_atomic(fs::path(o.out) / "compare.json", compare_json(ls, rb, rb0).dump(2) + "\n");
    write_file_atomic(fs::path(o.out) / "report.md", compare_markdown(ls, rb, rb0, note));
    if (o.view) write_view(o.out);
    std::printf("%s\n%s\n%s", console_summary(ls).c_str(), console_summary(rb).c_str(), console_summary(rb0).c_str());
    std::printf("\nphysics step, median CPU: lockstep %.2f us, rollback %.2f us (paper, Photon Quantum: 189.8 us)\n",
                ls.physics_step_us.percentile(50), rb.physics_step_us.percentile(50));
    std::printf("written %s/compare.json, report.md%s\n", o.out.c_str(), plot_error.empty() ? ", *.png" : "");
    if (!plot_error.empty()) std::fprintf(stderr, "warning: %s\n", plot_error.c_str());
    if (!ls.completed || !rb.completed || !rb0.completed) throw std::runtime_error("a run did not complete");
}

struct SweepOptions {
    std::vector<int> delays{0, 1, 2, 3, 4, 6};
    std::vector<int> windows{0, 2, 4, 8};
    std::vector<double> latencies{15, 30, 60, 100};
    bool adaptive = true;  // also one adaptive-delay run per window and latency
};

void do_sweep(const RunOptions& base, const SweepOptions& s) {
    std::string csv =
        "input_delay,prediction,latency_ms,mean_error,max_error,input_latency_ms,cpu_us_per_tick,ticks_per_second,"
        "stall_fraction,rollbacks_per_second,confirmed_mismatches,adaptive\n";
    std::vector<std::string> delays;
    for (int d : s.delays) delays.push_back(std::to_string(d));
    if (s.adaptive) delays.emplace_back("adaptive");
    const std::size_t total = delays.size() * s.windows.size() * s.latencies.size();
    std::size_t done = 0;
    for (double lat : s.latencies)
        for (int w : s.windows)
            for (const std::string& d : delays) {
                RunOptions o = base;
                o.mode = w == 0 ? "lockstep" : "rollback";
                o.prediction = w == 0 ? 8 : w;
                o.input_delay = d;
                o.latency = lat;
                RunConfig cfg = to_config(o);
                cfg.progress = nullptr;
                cfg.evidence_dir.clear();
                const RunResult r = run_match(cfg);
                char line[320];
                // The adaptive row's delay is the mean each client used over the match.
                std::snprintf(line, sizeof line, "%.3g,%d,%g,%.9g,%.9g,%.3f,%.3f,%.3f,%.4f,%.3f,%llu,%d\n",
                              r.input_delay_used.mean(), w, lat,
                              r.position_error.mean(), r.position_error.max, r.input_latency_local.mean(),
                              r.cpu_us_per_tick.mean(), r.ticks_per_second(), r.stall_fraction(),
                              r.virtual_seconds > 0 ? static_cast<double>(r.rollbacks()) / r.virtual_seconds / r.players : 0.0,
                              static_cast<unsigned long long>(r.confirmed_mismatches), r.adaptive_delay ? 1 : 0);
                csv += line;
                ++done;
                if (::isatty(2)) std::fprintf(stderr, "\r[sweep] %zu / %zu runs ", done, total);
            }
    if (::isatty(2)) std::fprintf(stderr, "\n");
    fs::create_directories(base.out);
    write_file_atomic(fs::path(base.out) / "sweep.csv", csv);
    const std::string plot_error = run_plot_script("plot.py", {"sweep", base.out});
    std::printf("written %s/sweep.csv%s\n", base.out.c_str(), plot_error.empty() ? ", sweep.png" : "");
    if (!plot_error.empty()) std::fprintf(stderr, "warning: %s\n", plot_error.c_str());
}
}  // namespace

DesyncInjection parse_injection(const std::string& text) {
    // Each part is range-checked before it is narrowed: 4294967298 must not become frame 2.
    constexpr long long kMax[5] = {15, 0xFFFFFFFFll, 0xFFFFFFFFll, 5, 63};
    constexpr const char* kName[5] = {"CLIENT", "FRAME", "BODY", "FIELD", "BIT"};
    std::vector<long long> parts;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ':')) {
        char* end = nullptr;
        errno = 0;
        const long long v = std::strtoll(item.c_str(), &end, 10);
        if (item.empty() || *end != '\0' || v < 0 || errno == ERANGE)
            throw UsageError("--inject-desync " + text + ": expected CLIENT:FRAME:BODY[:FIELD:BIT] of non-negative integers");
        if (parts.size() < 5 && v > kMax[parts.size()])
            throw UsageError("--inject-desync " + text + ": " + kName[parts.size()] + " " + item + " is above " +
                             std::to_string(kMax[parts.size()]));
        parts.push_back(v);
    }
    if (parts.size() != 3 && parts.size() != 5) throw UsageError("--inject-desync " + text + ": expected CLIENT:FRAME:BODY[:FIELD:BIT]");
    DesyncInjection d;
    d.client = static_cast<int>(parts[0]);
    d.frame = static_cast<std::uint32_t>(parts[1]);
    d.body = static_cast<std::uint32_t>(parts[2]);
    if (parts.size() == 5) {
        d.field = static_cast<int>(parts[3]);
        d.bit = static_cast<int>(parts[4]);
    }
    return d;
}


void add_run_command(CLI::App& app) {
    auto o = std::make_shared<RunOptions>();
    CLI::App* cmd = app.add_subcommand("run", "Run N clients in one mode over the simulated network; write DIR/summary.json");
    add_common(cmd, *o, true);
    cmd->callback([o] { do_run(*o); });
}

void add_compare_command(CLI::App& app) {
    auto o = std::make_shared<RunOptions>();
    o->out = "out/compare";
    CLI::App* cmd = app.add_subcommand(
        "compare", "Run lockstep and rollback on the same scene, network and seed; write DIR/report.md and plots");
    add_common(cmd, *o, false);
    cmd->callback([o] { do_compare(*o); });
}

void add_sweep_command(CLI::App& app) {
    auto o = std::make_shared<RunOptions>();
    auto s = std::make_shared<SweepOptions>();
    o->out = "out/sweep";
    o->frames = 600;
    CLI::App* cmd = app.add_subcommand(
        "sweep", "Input delay x prediction window x latency grid: error and input latency against CPU (DIR/sweep.csv)");
    add_common(cmd, *o, false);
    cmd->add_option("--delays", s->delays, "Input delays to try (frames)")->delimiter(',');
    cmd->add_option("--windows", s->windows, "Prediction windows to try (0 = lockstep)")->delimiter(',');
    cmd->add_option("--latencies", s->latencies, "One-way latencies to try (ms)")->delimiter(',');
    cmd->add_flag("!--no-adaptive", s->adaptive, "Leave out the adaptive-delay run of each window and latency");
    cmd->callback([o, s] { do_sweep(*o, *s); });
}

}  // namespace lockroll::harness
