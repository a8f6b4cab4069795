// `lockroll peer`: one player of a peer-to-peer match as its own process, over ENet on loopback.
//
// Builds the World and a Session for --slot of --players, binds ENet to --listen, connects to
// the --peer SLOT=HOST:PORT addresses and runs the session in real time with net::PeerRunner,
// driven by a bot. Outputs in --out DIR (the per-process counterpart of `lockroll run`):
//   summary.json    the keys of run's summary.json that make sense for one process, plus
//                   slot, outcome, final_checksum, wall_seconds, longest_stall_ms, runner figures
//   events.jsonl    one JSON object per lifecycle event:
//                   {"t_ms", "mono_ms", "frame", "event", "slot", ...}; events: listening,
//                   connected, synchronized, disconnected, desync, desync_report, peer_error,
//                   all_confirmed, finished
//   frames.csv      per shown frame: frame,wall_ms,confirmed_frame,rollback_depth,
//                   ticks_per_second,cpu_us
//   positions.csv   every dynamic body's shown position per frame, as `run --positions` writes
//                   it (frame,client,body_index,x,y,z) plus the exact Q32.32 raw values
//   peer.log        spdlog log (--log-level), also on stderr
// With --progress, prints "progress FRAME" on stdout whenever the shown frame advances (what
// `lockroll live` watches to --kill a process at a frame).
// Exit status: 0 when every peer confirmed the last frame, 1 otherwise, 2 for bad flags
// (checked before anything is bound or written).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "sim/scene.h"

namespace lockroll::harness {

void add_peer_command(CLI::App& app);

// A --match-id or --room name as its 64-bit id (FNV-1a): what peers and the relay server match on
// (`lockroll token` grants the same id).
std::uint64_t match_hash(const std::string& id);
// The scene a client plays: --scene with --players and --tick-rate, validated (UsageError).
sim::SceneDesc client_scene(const std::string& scene, int players, int tick_rate);

}  // namespace lockroll::harness
