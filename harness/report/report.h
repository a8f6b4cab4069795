// Turning a RunResult into what people and scripts read: summary.json, frames.csv, the
// one-screen console summary, and the lockstep-vs-rollback comparison (compare.json, report.md).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "harness/match/metrics.h"

namespace lockroll::harness {

// Per-packet header estimates for bandwidth on the wire (docs/network-model.md).
inline constexpr double kUdpHeaderBytes = 28;   // IPv4 20 + UDP 8
inline constexpr double kEnetHeaderBytes = 38;  // + ENet protocol header and unsequenced command

// A figure as printf(format, value) when the Stat it comes from has samples, else "n/a": the one
// rule every table follows (a number is measured, or n/a; the tables with room say why).
std::string figure(const Stat& from, const char* format, double value);

nlohmann::json summary_json(const RunResult& r);
std::string frames_csv(const RunResult& r);
// time_s,client,frame,kind,value: losses, stalls, rollbacks, corrections, time-sync waits.
std::string events_csv(const RunResult& r);
// time_s,client,frame,frames_ahead,wait_frames: every client's time sync, tick by tick.
std::string timesync_csv(const RunResult& r);
std::string console_summary(const RunResult& r);
// The clients of an in-process match that ended partitioned (issue 21), for the console and the
// CLI's error: "client 2 since frame 118, client 5 since frame 117"; "" when none did.
std::string partitioned_clients(const RunResult& r);

// Writes summary.json, frames.csv, events.csv, timesync.csv and (when recorded) positions.csv
// into dir, atomically.
void write_run(const std::filesystem::path& dir, const RunResult& r);

// The seed paper's figures, for the side-by-side table.
struct PaperFigures {
    static constexpr double quantum_mean_error = 0.000178853;
    static constexpr double quantum_max_error = 0.4419556;
    static constexpr double quantum_latency_ms = 57;
    static constexpr double quantum_step_ms = 0.1898;
    static constexpr double lockstep_ticks_per_second = 7;
};

// The paper's conditions: 2 players on its scene at 60 Hz, 57 ms read either as round trip
// (28.5 ms one way) or one way, ±10 ms jitter, no loss, duplication or reordering. Its figures
// are shown beside ours only then.
bool at_paper_conditions(const RunResult& r);

// rollback_delay0 is the like-for-like run: rollback at input delay 0 (what the paper measured).
nlohmann::json compare_json(const RunResult& lockstep, const RunResult& rollback, const RunResult& rollback_delay0);
// One run's figures as compare_markdown's table has them (one column), under "# lockroll: TITLE".
std::string run_markdown(const RunResult& r, const std::string& title);
std::string compare_markdown(const RunResult& lockstep, const RunResult& rollback, const RunResult& rollback_delay0,
                             const std::string& plots_note);

}  // namespace lockroll::harness
