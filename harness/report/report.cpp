#include "harness/report/report.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <sstream>
#include <string_view>

#include "harness/match/atomic_file.h"
#include "harness/match/hex.h"

namespace lockroll::harness {

namespace {
using nlohmann::json;


// mean, percentiles and max of a Stat that keeps its samples.
json spread_json(const Stat& s) {
    return {{"mean", s.mean()},      {"p50", s.percentile(50)}, {"p95", s.percentile(95)},
            {"p99", s.percentile(99)}, {"max", s.max},           {"samples", s.count}};
}

json error_json(const Stat& s) {
    return {{"mean", s.mean()}, {"max", s.max}, {"nonzero", s.nonzero}, {"samples", s.count}};
}

// Which bodies carry the error: players against the rest, and the bodies with the most
// non-zero samples (at most 20, so a 10k-body scene stays readable).
json error_by_body_json(const RunResult& r) {
    Stat players, others;
    std::vector<std::size_t> order;
    for (std::size_t b = 0; b < r.body_error.size(); ++b) {
        const Stat& e = r.body_error[b];
        Stat& into = b < r.body_player.size() && r.body_player[b] >= 0 ? players : others;
        into.sum += e.sum;
        into.max = std::max(into.max, e.max);
        into.count += e.count;
        into.nonzero += e.nonzero;
        if (e.nonzero) order.push_back(b);
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return r.body_error[a].nonzero > r.body_error[b].nonzero; });
    if (order.size() > 20) order.resize(20);
    json top = json::array();
    for (std::size_t b : order)
        top.push_back({{"body", b < r.body_ids.size() ? r.body_ids[b] : b},
                       {"player", b < r.body_player.size() ? r.body_player[b] : -1},
                       {"nonzero", r.body_error[b].nonzero},
                       {"mean", r.body_error[b].mean()},
                       {"max", r.body_error[b].max}});
    return {{"players", error_json(players)}, {"other_bodies", error_json(others)}, {"top_bodies", top}};
}

// A header, then one line per item written by `line_of` into a buffer.
template <class T, class F>
std::string csv_of(const char* header, const std::vector<T>& items, F line_of) {
    std::string out = header;
    char line[192];
    for (const T& item : items) {
        line_of(item, line, sizeof line);
        out += line;
    }
    return out;
}

std::string fmt(const char* f, double v) {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// "p50 X ms, p95 Y ms" of the run's measured round trip, or n/a with the reason.
std::string rtt_header(const RunResult& r) {
    if (const auto it = r.unmeasured.find("measured_rtt"); it != r.unmeasured.end()) return "n/a: " + it->second;
    return "p50 " + fmt("%.1f", r.rtt_p50_ms) + " ms, p95 " + fmt("%.1f", r.rtt_p95_ms) + " ms";
}

// text when the Stat has samples, else "n/a".
std::string or_na(const Stat& s, const std::string& text) { return s.count ? text : std::string("n/a"); }
}  // namespace

std::string figure(const Stat& from, const char* format, double value) { return or_na(from, fmt(format, value)); }

json summary_json(const RunResult& r) {
    json finals = json::array();
    for (const auto& c : r.clients) finals.push_back(c.final_confirmed ? json(hex16(c.final_checksum)) : json(nullptr));
    json clients = json::array();
    for (const auto& c : r.clients) {
        clients.push_back({{"ticks_per_second", c.ticks_per_second},
                           {"stall_fraction", c.stall_fraction},
                           {"frames", c.frames},
                           {"ticks", c.ticks},
                           {"stall_ticks", c.stall_ticks},
                           {"time_sync_wait_frames", c.time_sync_waits},
                           {"rollbacks", c.rollbacks},
                           {"resimulated_frames", c.resimulated_frames},
                           {"max_rollback_depth", c.max_rollback_depth},
                           {"mispredictions", c.mispredictions},
                           {"bytes_sent", c.bytes_sent},
                           {"bytes_received", c.bytes_received},
                           {"packets_sent", c.packets_sent},
                           {"packets_received", c.packets_received},
                           {"malformed_packets", c.malformed_packets},
                           {"desyncs", c.desyncs}});
        if (c.outcome) clients.back()["outcome"] = c.outcome;
        // Present only when true of the client (issue 21: rejoined after a healed partition, or
        // partitioned at the end).
        if (c.partitioned_since_frame) clients.back()["partitioned_since_frame"] = *c.partitioned_since_frame;
        if (c.alone_since_frame) clients.back()["alone_since_frame"] = *c.alone_since_frame;
        if (c.rejoined_at_frame) clients.back()["rejoined_at_frame"] = *c.rejoined_at_frame;
    }
    json desyncs = json::array();
    for (const auto& d : r.desyncs)
        desyncs.push_back({{"client", d.client},
                           {"alert_ms", d.alert_ms},
                           {"report_ms", d.report_ms},
                           {"detected_frame", d.detected_frame},
                           {"frame", d.frame},
                           {"body", d.body},
                           {"field", d.field},
                           {"summary", d.summary},
                           {"evidence_file", d.evidence_file}});
    const double rps = r.virtual_seconds > 0 ? static_cast<double>(r.rollbacks()) / r.virtual_seconds /
                                                   static_cast<double>(std::max<std::size_t>(1, r.clients.size()))
                                             : 0;
    const double pps = r.packets_sent_per_s();
    Stat alert, report;
    for (const auto& d : r.desyncs) {
        alert.add(d.alert_ms);
        report.add(d.report_ms);
    }
    json pairs = json::array();
    {
        std::size_t k = 0;
        for (int a = 0; a < r.players; ++a)
            for (int b = a + 1; b < r.players && k < r.pair_error.size(); ++b, ++k) {
                json e = error_json(r.pair_error[k]);
                e["clients"] = {a, b};
                pairs.push_back(e);
            }
    }
    json shown_vs_confirmed = json::array();
    for (std::size_t c = 0; c < r.displayed_vs_confirmed.size(); ++c) {
        json e = error_json(r.displayed_vs_confirmed[c]);
        e["client"] = c;
        shown_vs_confirmed.push_back(e);
    }
    json rtt = json::array();
    for (const auto& p : r.rtt)
        rtt.push_back({{"client", p.client},
                       {"peer", p.peer},
                       {"p50", p.rtt_ms.percentile(50)},
                       {"p99", p.rtt_ms.percentile(99)},
                       {"samples", p.rtt_ms.count}});
    json local = spread_json(r.input_latency_local);
    json summary = {
        {"mode", r.mode},
        {"scene", r.scene},
        {"players", r.players},
        {"frames", r.frames},
        {"seed", r.seed},
        {"bot", r.bot},
        {"tick_rate", r.tick_rate},
        {"network",
         {{"latency_ms_one_way", r.latency_ms},
          {"jitter_ms", r.jitter_ms},
          {"loss", r.loss},
          {"duplicate", r.duplicate},
          {"reorder", r.reorder},
          {"measured_rtt_ms", {{"p50", r.rtt_p50_ms}, {"p95", r.rtt_p95_ms}}}}},
        {"completed", r.completed},
        {"virtual_seconds", r.virtual_seconds},
        {"ticks_per_second", r.ticks_per_second()},
        {"stall_fraction", r.stall_fraction()},
        {"input_delay_frames", r.input_delay},
        {"input_delay",
         {{"adaptive", r.adaptive_delay},
          {"start", r.input_delay},
          {"min", r.input_delay_min},
          {"max", r.input_delay_max},
          {"mean", r.input_delay_used.mean()},
          {"changes", r.input_delay_changes}}},
        {"prediction_window", r.prediction},
        // Top level: local (kept for scripts reading mean/max); "local" and "remote" in full.
        {"input_latency_ms",
         {{"mean", local["mean"]},
          {"p50", local["p50"]},
          {"p95", local["p95"]},
          {"p99", local["p99"]},
          {"max", local["max"]},
          {"samples", local["samples"]},
          {"local", local},
          {"remote", spread_json(r.input_latency_remote)}}},
        {"rtt_ms", rtt},
        {"position_error", error_json(r.position_error)},
        {"position_error_by_pair", pairs},
        {"displayed_vs_confirmed", shown_vs_confirmed},
        {"error_by_body", error_by_body_json(r)},
        {"desync_detection_ms",
         {{"reports", alert.count},
          {"alert_mean", alert.mean()},
          {"alert_max", alert.max},
          {"report_mean", report.mean()},
          {"report_max", report.max}}},
        {"tick_budget_us", r.tick_budget_us()},
        {"worst_tick_us", r.cpu_us_per_tick.max},
        {"p99_tick_us", r.cpu_us_per_tick.percentile(99)},
        {"resim_frames_per_s", r.resim_frames_per_s()},
        {"full_window_rollback_us", r.full_window_rollback_us()},
        {"visual_corrections",
         {{"count", r.correction_jump.count}, {"mean_jump_m", r.correction_jump.mean()}, {"max_jump_m", r.correction_jump.max}}},
        {"confirmed_mismatches", r.confirmed_mismatches},
        {"confirmed_compared", r.confirmed_compared},
        {"desyncs", r.desync_count()},
        {"desync_reports", desyncs},
        {"rollbacks",
         {{"count", r.rollbacks()},
          {"per_second", rps},
          {"mean_depth", r.rollback_depth.mean()},
          {"max_depth", r.rollback_depth.max},
          {"depth_histogram", r.rollback_depth_histogram}}},
        {"cpu_us_per_tick",
         {{"mean", r.cpu_us_per_tick.mean()},
          {"p99", r.cpu_us_per_tick.percentile(99)},
          {"resim_mean", r.resim_us_per_tick.mean()}}},
        {"physics_step_us",
         {{"median", r.physics_step_us.percentile(50)},
          {"p99", r.physics_step_us.percentile(99)},
          {"steps", r.physics_step_us.count}}},
        {"bandwidth_bytes_per_s",
         {{"sent", r.bytes_sent_per_s()},
          {"received", r.bytes_received_per_s()},
          {"packets_sent_per_s", pps},
          {"sent_with_udp_headers", r.bytes_sent_per_s() + pps * kUdpHeaderBytes},
          {"sent_with_enet_headers", r.bytes_sent_per_s() + pps * kEnetHeaderBytes}}},
        {"final_checksums", finals},
        {"clients", clients},
    };
    // Only with --partition: a run without cuts writes exactly what it wrote before.
    if (r.partition_cuts > 0)
        summary["network"]["partition"] = {{"cuts", r.partition_cuts}, {"dropped_datagrams", r.partitioned_datagrams}};
    return summary;
}

std::string frames_csv(const RunResult& r) {
    return csv_of("frame,time_s,mean_error,max_error,rollbacks,max_rollback_depth,ticks_per_second\n", r.rows,
                  [](const FrameRow& row, char* line, std::size_t n) {
                      std::snprintf(line, n, "%u,%.6f,%.9g,%.9g,%u,%u,%.3f\n", row.frame, row.time_s, row.mean_error,
                                    row.max_error, row.rollbacks, row.max_rollback_depth, row.ticks_per_second);
                  });
}

std::string console_summary(const RunResult& r) {
    std::ostringstream o;
    o << r.mode << " on " << r.scene << ", " << r.players << " players, " << r.frames << " frames, seed " << r.seed
      << (r.completed ? "" : "  ** INCOMPLETE: not every client confirmed the last frame **") << "\n";
    for (const auto& n : r.notes) o << "  note         " << n << "\n";
    o << "  network      one-way " << r.latency_ms << " ms +-" << r.jitter_ms << " ms, loss " << r.loss << ", dup "
      << r.duplicate << ", reorder " << r.reorder << "; measured RTT " << rtt_header(r) << "\n";
    if (r.partition_cuts > 0)
        o << "  partition    " << r.partition_cuts << (r.partition_cuts == 1 ? " cut" : " cuts") << ", "
          << r.partitioned_datagrams << " datagrams dropped across them\n";
    if (const std::string cut_off = partitioned_clients(r); !cut_off.empty())
        o << "  partitioned  " << cut_off << ": cut off from a majority of the view, not healed when the match ended\n";
    o << "  tick rate    " << fmt("%.2f", r.ticks_per_second()) << " ticks/s, stalls " << fmt("%.1f", 100 * r.stall_fraction())
      << " % of ticks; input delay " << r.input_delay << " frames, window " << r.prediction << "\n";
    o << "  input lag    local mean " << or_na(r.input_latency_local, fmt("%.1f", r.input_latency_local.mean()) + " ms") << " (max "
      << or_na(r.input_latency_local, fmt("%.1f", r.input_latency_local.max)) << "), remote mean "
      << or_na(r.input_latency_remote, fmt("%.1f", r.input_latency_remote.mean()) + " ms") << "\n";
    o << "  error        "
      << or_na(r.position_error, "mean " + fmt("%.3g", r.position_error.mean()) + " m, max " + fmt("%.3g", r.position_error.max) +
                                     " m, non-zero " + std::to_string(r.position_error.nonzero) + " of " +
                                     std::to_string(r.position_error.count) + " samples")
      << "\n";
    o << "  rollbacks    " << r.rollbacks() << " (mean depth " << fmt("%.2f", r.rollback_depth.mean()) << ", max "
      << fmt("%.0f", r.rollback_depth.max) << "), visual corrections " << r.correction_jump.count << " (max jump "
      << fmt("%.3g", r.correction_jump.max) << " m)\n";
    o << "  cpu          "
      << or_na(r.cpu_us_per_tick, fmt("%.1f", r.cpu_us_per_tick.mean()) + " us/tick mean, p99 " +
                                      fmt("%.1f", r.cpu_us_per_tick.percentile(99)) + " us (resimulation " +
                                      fmt("%.1f", r.resim_us_per_tick.mean()) + " us mean)")
      << "\n";
    o << "  bandwidth    " << fmt("%.0f", r.bytes_sent_per_s()) << " B/s payload sent per client ("
      << fmt("%.0f", r.bytes_sent_per_s() + r.packets_sent_per_s() * kUdpHeaderBytes) << " with UDP headers)\n";
    o << "  agreement    confirmed mismatches " << r.confirmed_mismatches << " of " << r.confirmed_compared
      << " checksums compared, desyncs " << r.desync_count() << "\n";
    for (const auto& d : r.desyncs) o << "  DESYNC       client " << d.client << ": " << d.summary << "\n";
    o << "  final        ";
    for (const auto& c : r.clients) o << (c.final_confirmed ? hex16(c.final_checksum) : std::string("(none)")) << " ";
    o << "\n";
    return o.str();
}

std::string partitioned_clients(const RunResult& r) {
    std::string out;
    for (std::size_t k = 0; k < r.clients.size(); ++k) {
        const ClientResult& c = r.clients[k];
        if (!c.outcome || std::string_view(c.outcome) != "partitioned") continue;
        out += (out.empty() ? "client " : ", client ") + std::to_string(k);
        if (c.partitioned_since_frame) out += " since frame " + std::to_string(*c.partitioned_since_frame);
    }
    return out;
}

std::string events_csv(const RunResult& r) {
    return csv_of("time_s,client,frame,kind,value\n", r.events, [](const RunEvent& e, char* line, std::size_t n) {
        std::snprintf(line, n, "%.6f,%d,%u,%s,%.9g\n", e.time_s, e.client, e.frame, e.kind, e.value);
    });
}

std::string timesync_csv(const RunResult& r) {
    return csv_of("time_s,client,frame,frames_ahead,wait_frames\n", r.time_sync,
                  [](const TimeSyncSample& t, char* line, std::size_t n) {
                      std::snprintf(line, n, "%.6f,%d,%u,%.2f,%d\n", t.time_s, t.client, t.frame, t.frames_ahead,
                                    t.wait_frames);
                  });
}

void write_run(const std::filesystem::path& dir, const RunResult& r) {
    std::filesystem::create_directories(dir);
    write_file_atomic(dir / "summary.json", summary_json(r).dump(2) + "\n");
    write_file_atomic(dir / "frames.csv", frames_csv(r));
    write_file_atomic(dir / "events.csv", events_csv(r));
    write_file_atomic(dir / "timesync.csv", timesync_csv(r));
    if (!r.positions_csv.empty()) write_file_atomic(dir / "positions.csv", r.positions_csv);
    if (!r.bodies_csv.empty()) write_file_atomic(dir / "bodies.csv", r.bodies_csv);
}

bool at_paper_conditions(const RunResult& r) {
    return r.scene == "paper" && r.players == 2 && r.tick_rate == 60 && (r.latency_ms == 28.5 || r.latency_ms == 57) &&
           r.jitter_ms == 10 && r.loss == 0 && r.burst_loss == 0 && r.duplicate == 0 && r.reorder == 0;
}

json compare_json(const RunResult& ls, const RunResult& rb, const RunResult& rb0) {
    json j = {{"lockstep", summary_json(ls)},
              {"rollback", summary_json(rb)},
              {"rollback_delay0", summary_json(rb0)},
              {"physics_step_us",
               {{"lockstep", ls.physics_step_us.percentile(50)}, {"rollback", rb.physics_step_us.percentile(50)}}},
              {"paper_conditions", at_paper_conditions(rb)}};
    if (at_paper_conditions(rb))
        j["paper"] = {{"quantum_rollback",
                       {{"mean_error", PaperFigures::quantum_mean_error},
                        {"max_error", PaperFigures::quantum_max_error},
                        {"latency_ms", PaperFigures::quantum_latency_ms},
                        {"step_ms", PaperFigures::quantum_step_ms}}},
                      {"custom_lockstep", {{"mean_error", 0.0}, {"max_error", 0.0}, {"ticks_per_second", 7.0}}}};
    return j;
}

namespace {

// The figures table: a row per figure, a column per run, then the paper's two figures when at
// its conditions. A figure is measured or printed "n/a [k]", k a footnote with the reason (the
// run's unmeasured[key], or that nothing was measured): never a 0 nobody measured.
std::string figures_table(const std::vector<std::pair<std::string, const RunResult*>>& columns, bool paper) {
    std::ostringstream o;
    std::vector<std::string> footnotes;
    const RunResult* current = nullptr;  // the run whose cell is being made
    std::string current_row;
    auto na = [&](const std::string& key) {
        const auto it = current->unmeasured.find(key);
        const std::string note = current_row + ", " + current->mode + ": " +
                                 (it != current->unmeasured.end() ? it->second : std::string("nothing was measured in this run"));
        auto at = std::find(footnotes.begin(), footnotes.end(), note);
        if (at == footnotes.end()) at = footnotes.insert(footnotes.end(), note);
        return "n/a [" + std::to_string(at - footnotes.begin() + 1) + "]";
    };
    // value(stat, key, text): text when the Stat has samples, else n/a with the footnote.
    auto measured = [&](const Stat& st, const std::string& key, const std::string& text) { return st.count ? text : na(key); };
    auto row = [&](const std::string& name, const std::function<std::string(const RunResult&)>& cell,
                   const std::string& paper_lockstep = "—", const std::string& paper_quantum = "—") {
        o << "| " << name;
        current_row = name;
        for (const auto& [title, r] : columns) {
            current = r;
            o << " | " << cell(*r);
        }
        if (paper) o << " | " << paper_lockstep << " | " << paper_quantum;
        o << " |\n";
    };
    auto count = [](std::uint64_t v) { return std::to_string(v); };
    o << "|";
    for (const auto& [title, r] : columns) o << " | " << title;
    if (paper) o << " | paper: custom lockstep | paper: Photon Quantum";
    o << " |\n|---";
    for (std::size_t k = 0; k < columns.size() + (paper ? 2 : 0); ++k) o << "|---";
    o << "|\n";
    row("ticks per second", [](const RunResult& r) { return fmt("%.2f", r.ticks_per_second()); }, "~7");
    row("stall fraction", [](const RunResult& r) { return fmt("%.3f", r.stall_fraction()); });
    row("input delay (frames)", [](const RunResult& r) { return std::to_string(r.input_delay); });
    auto spread = [&](const Stat& st, const std::string& key) {
        return measured(st, key,
                        fmt("%.1f", st.percentile(50)) + " / " + fmt("%.1f", st.percentile(95)) + " / " +
                            fmt("%.1f", st.percentile(99)) + " / " + fmt("%.1f", st.max));
    };
    row("input latency, local (ms)",
        [&](const RunResult& r) { return measured(r.input_latency_local, "input_latency_local", fmt("%.1f", r.input_latency_local.mean())); });
    row("input latency, remote (ms)", [&](const RunResult& r) {
        return measured(r.input_latency_remote, "input_latency_remote", fmt("%.1f", r.input_latency_remote.mean()));
    });
    row("local p50 / p95 / p99 / max (ms)", [&](const RunResult& r) { return spread(r.input_latency_local, "input_latency_local"); });
    row("remote p50 / p95 / p99 / max (ms)", [&](const RunResult& r) { return spread(r.input_latency_remote, "input_latency_remote"); });
    row("RTT p50 / p99, worst peer (ms)", [&](const RunResult& r) {
        double p50 = 0, p99 = 0;
        std::uint64_t samples = 0;
        for (const auto& p : r.rtt) {
            if (!p.rtt_ms.count) continue;
            samples += p.rtt_ms.count;
            p50 = std::max(p50, p.rtt_ms.percentile(50));
            p99 = std::max(p99, p.rtt_ms.percentile(99));
        }
        return samples ? fmt("%.1f", p50) + " / " + fmt("%.1f", p99) : na("rtt");
    });
    row("mean positional error (m)",
        [&](const RunResult& r) { return measured(r.position_error, "position_error", fmt("%.3g", r.position_error.mean())); }, "0",
        "1.79e-4");
    row("max positional error (m)",
        [&](const RunResult& r) { return measured(r.position_error, "position_error", fmt("%.3g", r.position_error.max)); }, "0", "0.442");
    row("non-zero error samples",
        [&](const RunResult& r) {
            return measured(r.position_error, "position_error", count(r.position_error.nonzero) + " / " + count(r.position_error.count));
        },
        "0 / >30,000", "160 / ~37,000");
    row("shown vs confirmed state, mean / max (m)", [&](const RunResult& r) {
        Stat all;
        for (const Stat& st : r.displayed_vs_confirmed) all.merge(st);
        return measured(all, "displayed_vs_confirmed", fmt("%.3g", all.mean()) + " / " + fmt("%.3g", all.max));
    });
    row("non-zero samples on player bodies", [&](const RunResult& r) {
        std::uint64_t players = 0;
        for (std::size_t b = 0; b < r.body_error.size(); ++b)
            if (b < r.body_player.size() && r.body_player[b] >= 0) players += r.body_error[b].nonzero;
        return measured(r.position_error, "position_error", count(players) + " of " + count(r.position_error.nonzero));
    }, "—", "107 of 160");
    row("confirmed-state mismatches (of checksums compared)", [&](const RunResult& r) {
        return r.confirmed_compared ? count(r.confirmed_mismatches) + " of " + count(r.confirmed_compared) : na("confirmed_compared");
    });
    row("rollbacks (mean / max depth)", [&](const RunResult& r) {
        return r.rollbacks() ? count(r.rollbacks()) + " (" + fmt("%.2f", r.rollback_depth.mean()) + " / " +
                                   fmt("%.0f", r.rollback_depth.max) + ")"
                             : std::string("0");
    });
    row("visual corrections (max jump m)", [&](const RunResult& r) {
        return r.correction_jump.count ? count(r.correction_jump.count) + " (" + fmt("%.3g", r.correction_jump.max) + ")"
                                       : std::string("0");
    });
    row("CPU per tick, mean / p99 (µs)", [&](const RunResult& r) {
        return measured(r.cpu_us_per_tick, "cpu_us_per_tick",
                        fmt("%.1f", r.cpu_us_per_tick.mean()) + " / " + fmt("%.1f", r.cpu_us_per_tick.percentile(99)));
    });
    row("worst / p99 tick vs budget (µs)", [&](const RunResult& r) {
        return measured(r.cpu_us_per_tick, "cpu_us_per_tick",
                        fmt("%.0f", r.cpu_us_per_tick.max) + " / " + fmt("%.0f", r.cpu_us_per_tick.percentile(99)) + " of " +
                            fmt("%.0f", r.tick_budget_us()));
    });
    row("resimulated frames per second", [](const RunResult& r) { return fmt("%.1f", r.resim_frames_per_s()); });
    row("full-window rollback, projected (µs)", [&](const RunResult& r) {
        if (!r.prediction) return std::string("—");
        if (!r.resimulated_frames() && !r.physics_step_us.count) return na("physics_step_us");
        return fmt("%.0f", r.full_window_rollback_us()) + " (W=" + std::to_string(r.prediction) + ")";
    });
    row("physics step, median CPU (µs)",
        [&](const RunResult& r) { return measured(r.physics_step_us, "physics_step_us", fmt("%.2f", r.physics_step_us.percentile(50))); },
        "—", "189.8");
    row("payload sent per client (B/s)", [](const RunResult& r) { return fmt("%.0f", r.bytes_sent_per_s()); });
    row("with UDP/IPv4 headers (B/s)", [](const RunResult& r) {
        return fmt("%.0f", r.bytes_sent_per_s() + r.packets_sent_per_s() * kUdpHeaderBytes);
    });
    row("desyncs", [&](const RunResult& r) { return count(r.desync_count()); });
    const bool any_desync =
        std::any_of(columns.begin(), columns.end(), [](const auto& c) { return !c.second->desyncs.empty(); });
    if (any_desync) {
        row("desync: shown -> alert / -> report (ms)", [](const RunResult& r) {
            double alert = 0, report = 0;
            for (const auto& d : r.desyncs) {
                alert = std::max(alert, d.alert_ms);
                report = std::max(report, d.report_ms);
            }
            return r.desyncs.empty() ? std::string("—") : fmt("%.1f", alert) + " / " + fmt("%.1f", report);
        });
    }
    if (!footnotes.empty()) {
        o << "\n";
        for (std::size_t k = 0; k < footnotes.size(); ++k) o << "[" << k + 1 << "] n/a: " << footnotes[k] << "\n";
    }
    for (const auto& [title, r] : columns)
        for (const auto& n : r->notes) o << "\nNote (" << title << "): " << n << "\n";
    return o.str();
}

std::string conditions_line(const RunResult& rb) {
    std::ostringstream o;
    o << "Scene `" << rb.scene << "`, " << rb.players << " players, " << rb.frames << " frames at " << rb.tick_rate
      << " Hz, seed " << rb.seed << ", bots `" << rb.bot << "`. Network: one-way latency " << rb.latency_ms << " ms ± "
      << rb.jitter_ms << " ms jitter, loss " << rb.loss << ", duplication " << rb.duplicate << ", reordering " << rb.reorder
      << " (measured RTT " << rtt_header(rb) << ").\n\n";
    return o.str();
}

}  // namespace

std::string run_markdown(const RunResult& r, const std::string& title) {
    return "# lockroll: " + title + "\n\n" + conditions_line(r) + figures_table({{"lockroll " + r.mode, &r}}, false);
}

std::string compare_markdown(const RunResult& ls, const RunResult& rb, const RunResult& rb0, const std::string& plots_note) {
    const bool paper = at_paper_conditions(rb);
    std::ostringstream o;
    o << "# lockroll: lockstep vs rollback\n\n" << conditions_line(rb);
    o << figures_table({{"lockroll lockstep", &ls},
                        {"lockroll rollback, input delay " + std::to_string(rb.input_delay) + (rb.input_delay == 0 ? "" : " (auto)"), &rb},
                        {"lockroll rollback, input delay 0 (like-for-like)", &rb0}},
                       paper);
    o << "\n";
    if (!paper)
        o << "The paper's figures are not shown: they were measured at 2 players, 57 ms ± 10 ms and no loss, "
             "and are only comparable at those conditions.\n\n";
    o << "The input delay 0 column is rollback as the paper ran it (every frame shown at once, all "
         "latency hidden by prediction); the auto column trades a little input delay for less "
         "misprediction, so its lower error is not a like-for-like win.\n\n";
    o << "Positional error is the paper's metric: every dynamic body's position as each client first "
         "showed it (forward simulation, not resimulation), compared between every pair of clients frame by frame. "
         "Lockstep only ever shows confirmed state, so its error is zero by construction; rollback's error "
         "comes from frames shown with predicted inputs before the real ones arrived. Confirmed-state "
         "mismatches count frames whose final checksums differ between clients, which must be 0 in both "
         "modes. CPU per tick is thread CPU time around the session's advance (steps, saves, checksums, "
         "rollbacks), without the harness's own measuring. The physics step is the median thread CPU "
         "time of every step (forward and resimulated) of this scene in this run.\n\n";
    o << plots_note;
    return o.str();
}

}  // namespace lockroll::harness
