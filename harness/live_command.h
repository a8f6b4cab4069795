// `lockroll live`: a networked match of real processes on loopback, measured like `compare`.
//
//   lockroll live --topology p2p --players N --frames F [--latency --jitter --loss --burst
//       --duplicate --reorder --seed] [--mode lockstep|rollback|both] [--kill SLOT@FRAME ...]
//       [--rejoin SLOT@FRAME] [--join SLOT@FRAME] [--spectators K]
//       [--inject-desync CLIENT:FRAME:BODY[:FIELD:BIT]] --out DIR
//
// Per mode: probes free UDP ports on 127.0.0.1, starts one `lockroll proxy` per peer in front of
// its listen port (when any impairment is asked for; each pair's traffic then crosses exactly
// one proxy, the higher slot's, which delays both directions), then N `lockroll peer --progress`
// processes; watches their progress lines (to SIGKILL a process at --kill SLOT@FRAME), waits
// for all of them within a bound (ten times the match length plus a minute), stops the proxies.
// It then reads every process's summary.json, frames.csv and positions.csv and builds one
// RunResult per mode -- the positional error is the paper's metric across processes -- and
// writes DIR/MODE/{summary.json,frames.csv,pK/...}, DIR/compare.json, DIR/report.md and the
// plots of `compare` (both modes, plus rollback at input delay 0 as compare's third column),
// with the in-process virtual-time match of the same flags beside it (DIR/virtual/MODE/), and
// DIR/live.json: per process exit status, outcome, final
// checksum, frames, disconnect frames, kill frame and the longest stall after a kill.
//
// Lifecycle: --kill SLOT@FRAME SIGKILLs that process once it shows FRAME; --rejoin SLOT@FRAME
// restarts a killed slot with `peer --join` once slot 0 shows FRAME; --join SLOT@FRAME starts
// the match without that slot (every process gets --absent SLOT) and its process joins at FRAME;
// --spectators K adds K `peer --spectate` processes. docs/sessions.md has the details.
// Exit status: 0 when every process that was not killed completed and all final confirmed
// checksums agree; 1 otherwise; 2 bad flags (checked before any process starts).
//
// Where it lives: this file turns the flags into a checked plan (harness/live/live_plan.h) and
// writes the run's files; the processes are run by harness/live/live_processes.h and every
// figure of the report is built from their raw files by harness/live/live_report.h.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_live_command(CLI::App& app);

}  // namespace lockroll::harness
