// The orchestration of one mode of a `lockroll live` run: real processes on 127.0.0.1.
//
// Probes free UDP ports, starts the relay server first (relay topology), one `lockroll proxy`
// per player in front of its port when any impairment or partition is asked for (each pair's
// traffic then crosses exactly one proxy, the higher slot's, which delays both directions), then
// the `lockroll peer` (or `client`) processes with --progress; starts late joiners, rejoiners
// and spectators when the reference slot shows their frame, SIGKILLs a slot at its --kill
// frame, waits for every process within a bound (ten times the match length plus a minute,
// after which the rest are stopped), stops the proxies, drains the server, and reads back what
// each process wrote (summary.json, events.jsonl). Children are stopped by their pid only.
// Reads the clock (net/clock.h) for the deadlines, never for a figure.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/live/live_plan.h"

namespace lockroll::harness {

// What one process of the run did, as the orchestration saw it and as it wrote it.
struct ProcessRecord {
    int slot = 0;                // player slot, or spectator id (>= players)
    bool spectator = false;
    bool joiner = false;         // starts late: --join, --rejoin, or --restart (see restart)
    bool restart = false;        // a --restart: a killed slot's process again, WITHOUT --join
    std::string name;            // output directory under the mode's directory
    int exit_status = -1;
    std::string failure;         // a failed process's own word on why (failure_line of its stderr log)
    bool started = false;
    bool killed = false;
    int killed_at_frame = -1;
    std::uint64_t killed_mono_us = 0;
    int last_progress = 0;
    // Start condition: when player `after_slot` has shown `after_frame` (and, for a rejoin,
    // once `after_kill_of` has been killed). -1: at once.
    int after_slot = -1, after_frame = 0, after_kill_of = -1;
    nlohmann::json summary;  // null when the process left none (killed)
    std::vector<nlohmann::json> events;
};

// Runs one mode's processes into dir (dir/NAME/ per process); returns what each did (players
// first, by slot; then rejoined players and spectators). relay: every client talks to one
// `lockroll server` (through its own proxy when impaired) instead of to every other peer;
// *server gets the server's final status (discarded json when it wrote none). Throws
// std::runtime_error when a proxy or the server does not start.
std::vector<ProcessRecord> run_processes(const LivePlan& p, Mode mode, const std::filesystem::path& dir, int input_delay,
                                         bool relay, nlohmann::json* server);

}  // namespace lockroll::harness
