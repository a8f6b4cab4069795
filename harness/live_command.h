// `lockroll live`: a networked match of real processes on loopback, measured like `compare`.
//
//   lockroll live --topology p2p --players N --frames F [--latency --jitter --loss --burst
//       --duplicate --reorder --seed] [--mode lockstep|rollback|both] [--kill SLOT@FRAME ...]
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
// plots of `compare` (both modes), with the in-process virtual-time match of the same flags
// beside it (DIR/virtual/MODE/), and DIR/live.json: per process exit status, outcome, final
// checksum, frames, disconnect frames, kill frame and the longest stall after a kill.
//
// --rejoin, --join and --spectators need the session lifecycle (issue 7, the lead's part) and
// are refused with exit 2 until the session offers them. Exit status: 0 when every process that
// was not killed completed and all final confirmed checksums agree; 1 otherwise; 2 bad flags.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_live_command(CLI::App& app);

}  // namespace lockroll::harness
