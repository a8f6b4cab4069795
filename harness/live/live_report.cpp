#include "harness/live/live_report.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "harness/live/process_output.h"
#include "harness/match/hex.h"
#include "harness/match/match_recorder.h"
#include "harness/report/report.h"
#include "sim/world.h"

namespace lockroll::harness {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

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

}  // namespace

RunResult live_run_result(const LivePlan& p, Mode mode, const fs::path& dir, const std::vector<ProcessRecord>& all, int input_delay) {
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
                              std::to_string(rec.exit_status) + (rec.failure.empty() ? "" : ": " + rec.failure) +
                              "; its log: " + rec.name + ".stderr.log); it counts in no figure");
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
        else if (s.contains("rejoined_at_frame"))
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): " + s.value("outcome_detail", "") +
                              " (by snapshot, after the others dropped its slot); its figures count before and after");
        else if (s.contains("partitioned_since_frame"))
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): " + s.value("outcome_detail", "") +
                              "; its figures count up to then");
        if (s.contains("alone_since_frame") && s.value("outcome", "") == "completed")
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): completed alone since frame " +
                              s.value("alone_since_frame", json(nullptr)).dump() +
                              " (a drop left it the only player of its view; it agreed with nobody since)");
        // nlohmann's const operator[] on a missing key is undefined behaviour: a summary.json
        // cut short or written by another version must read as "not collected", never crash.
        const bool final_confirmed = s.value("final_checksum", json(nullptr)).is_string();
        if (!final_confirmed || rec.exit_status != 0) r.completed = false;
        r.virtual_seconds = std::max(r.virtual_seconds, s.value("wall_seconds", 0.0));
        if (rec.spectator) continue;  // a spectator confirms (agreement) but plays no frame of its own
        const json clients = s.value("clients", json::array());
        if (!clients.is_array() || clients.empty() || !clients[0].is_object()) {
            r.completed = false;
            r.notes.push_back(rec.name + " (slot " + std::to_string(rec.slot) + "): summary.json has no client figures");
            continue;
        }
        const json& c0 = clients[0];
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
        for (const auto& d : s.value("desync_reports", json::array())) {
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

json live_json(const std::vector<ProcessRecord>& recs, const fs::path& dir) {
    std::uint64_t first_kill = 0;
    for (const auto& r : recs)
        if (r.killed && (!first_kill || r.killed_mono_us < first_kill)) first_kill = r.killed_mono_us;
    json procs = json::array();
    // finals: every final of a process not killed; agreeing: those that claim agreement (a
    // process that says it played alone claims none: issue 21, a view of two cut apart).
    std::vector<std::string> finals, agreeing;
    int alone = 0;
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
                  {"role", r.spectator ? "spectator" : r.restart ? "restarted" : r.joiner ? "joiner" : "player"},
                  {"exit_status", r.exit_status},
                  {"failure", r.failure},
                  {"outcome", s.is_object() ? s.value("outcome", "") : (r.killed ? "killed" : "no summary")},
                  {"final_checksum", s.is_object() ? s.value("final_checksum", json(nullptr)) : json(nullptr)},
                  {"frames_shown", s.is_object() ? s.value("shown_frame", 0) : r.last_progress},
                  {"confirmed_frame", s.is_object() ? s.value("confirmed_frame", 0) : 0},
                  {"ticks_per_second", s.is_object() ? s.value("ticks_per_second", json(nullptr)) : json(0)},
                  {"stall_fraction", s.is_object() ? s.value("stall_fraction", json(nullptr)) : json(nullptr)},
                  {"longest_stall_ms", s.is_object() ? s.value("longest_stall_ms", json(nullptr)) : json(nullptr)},
                  {"clock_skew_ppm", s.is_object() ? s.value("clock_skew_ppm", 0) : 0},
                  {"snapshot_chunks_damaged", s.is_object() ? s.value("snapshot_chunks_damaged", 0) : 0},
                  {"outcome_detail", s.is_object() ? s.value("outcome_detail", "") : ""},
                  {"partitioned_since_frame", s.is_object() ? s.value("partitioned_since_frame", json(nullptr)) : json(nullptr)},
                  {"alone_since_frame", s.is_object() ? s.value("alone_since_frame", json(nullptr)) : json(nullptr)},
                  {"rejoined_at_frame", s.is_object() ? s.value("rejoined_at_frame", json(nullptr)) : json(nullptr)},
                  {"killed_at_frame", r.killed ? json(r.killed_at_frame) : json(nullptr)},
                  {"disconnects", disconnects},
                  {"joins", joins},
                  {"longest_stall_after_kill_ms",
                   first_kill && !r.killed && !r.joiner ? json(longest_stall_after(r, dir, first_kill)) : json(nullptr)}};
        if (!r.killed && s.is_object() && s.value("final_checksum", json(nullptr)).is_string()) {
            finals.push_back(s["final_checksum"]);
            if (s.contains("alone_since_frame")) ++alone;
            else agreeing.push_back(s["final_checksum"]);
        }
        procs.push_back(p);
    }
    // A split run (issue 21): the processes cut off from a majority say "partitioned" and exit 1,
    // truthfully, or "failed" (kicked once the network healed, with the frame they had been
    // partitioned since) when they could not rejoin; that is the network's doing, not a failure
    // of the match or the harness. The run fails only if a process that was neither killed nor on
    // the cut-off side did not complete, or two final checksums differ (overclaims are added by
    // the caller). Every process partitioned (no majority anywhere) is a split with nobody
    // completed, which is not a failure either. A cut-off process that rejoined the majority's
    // view by snapshot once healed and completed is no split side: it counts as completed, and
    // its final must be everyone's like any other.
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
    const auto one_final = [](const std::vector<std::string>& v) {
        return !v.empty() && std::all_of(v.begin(), v.end(), [&](const auto& f) { return f == v[0]; });
    };
    const bool equal = one_final(finals);
    // Completions that claim agreement must agree; one that says "alone" is checked against its
    // view by the overclaims (outcome_claims.h), not against the others' finals.
    const bool agreed = agreeing.empty() ? partitioned > 0 || alone > 0 : one_final(agreeing);
    return {{"processes", procs},
            {"final_checksums_equal", equal},
            {"agreeing_finals_equal", agreed},
            {"alone", alone},
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

}  // namespace lockroll::harness
