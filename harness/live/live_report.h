// The report of a `lockroll live` run, built only from what its processes wrote.
//
//  - live_run_result: one mode's RunResult from every process's summary.json (session
//    counters), samples.json (the one recorder's raw samples, harness/match/match_recorder.h),
//    frames.csv and positions.csv. Every percentile and maximum is computed from the samples; a
//    process that wrote nothing (killed on purpose) is named in the notes and counts in no
//    figure; a figure no process measured stays empty, printed "n/a" with the reason in
//    RunResult::unmeasured. The position error is the paper's metric across processes, every
//    frame between every pair of slots that both showed it; the agreement compares every
//    confirmed checksum every process wrote.
//  - live_json: live.json's per-mode entry: per process its exit status, outcome, final
//    checksum, frames, drops and joins, kill frame and the longest stall after a kill; whether
//    the final checksums agree and the survivors completed (a partition's cut-off side is the
//    network's doing, not a failure). `ok` needs the finals of the completions that claim
//    agreement to be one; a process that says it played alone (alone_since_frame) claims none
//    and is exempt (two survivors of a view of two cut apart each end on their own final), its
//    claim checked against its view by outcome_claims.h instead.
//  - side_by_side, topology_table: report.md's tables of real processes beside virtual time,
//    and of peer to peer against the relay server.
#pragma once

#include <filesystem>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/live/live_plan.h"
#include "harness/live/live_processes.h"
#include "harness/match/metrics.h"

namespace lockroll::harness {

RunResult live_run_result(const LivePlan& p, Mode mode, const std::filesystem::path& dir, const std::vector<ProcessRecord>& all,
                          int input_delay);
nlohmann::json live_json(const std::vector<ProcessRecord>& recs, const std::filesystem::path& dir);
std::string side_by_side(const std::vector<std::pair<std::string, const RunResult*>>& runs);
// rows: name, result, and for a relay run {"server": its status, "replaced": inputs replaced}.
std::string topology_table(const std::vector<std::tuple<std::string, const RunResult*, nlohmann::json>>& rows, int frames,
                           int tick_rate);

}  // namespace lockroll::harness
