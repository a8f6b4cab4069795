// The small values a game exchanges with either session (P2P Session, RelaySession) each tick
// and reads from them: player ids, the datagram it hands to its transport, what a tick did, the
// session's phase, a slot's state, the role a process asks for, and the counters a session keeps
// about itself (stats()). Installed: the sessions' public headers name these, so they live apart
// from the wire codecs (protocol.h, control_messages.h, relay_messages.h), which use the same
// enums and say which byte values are valid on the wire.
//
// Players are value ids: the player slot 0..players-1. In a peer-to-peer session each client has
// one local player, so a player id is also the peer id of that player's client; the transport
// maps ids to addresses, rollback/ never sees one.
//
// Stats times: *_ns are CPU-side durations measured with the session's cpu clock (telemetry
// only: nothing the session decides depends on them); *_us are virtual times from the now_us
// values the caller passes in.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace lockroll::rollback {

using PlayerId = std::uint32_t;

// Upper bound on players per session (inputs of all players travel in one step() call, and
// per-frame prediction masks are one 64-bit word).
inline constexpr int kMaxPlayers = 64;

// What a peer asks to be when it says hello (P2P; SessionConfig::role).
enum class Role : std::uint8_t {
    Player = 0,     // a slot present from frame 0
    Joiner = 1,     // a slot joining (or rejoining) a running match by snapshot
    Spectator = 2,  // follows the match, never sends inputs
};

// The same through the relay server (RelaySessionConfig::role).
enum class RelayRole : std::uint8_t { Player = 0, Joiner = 1, Spectator = 2 };

// A player slot's lifecycle state as peers gossip it (docs/sessions.md). Each change bumps the
// slot's epoch; the higher epoch wins, so every peer converges on one table.
enum class SlotState : std::uint8_t {
    Absent = 0,        // nobody plays it yet: its input is the flagged neutral input
    Running = 1,       // its owner process sends its inputs
    Disconnected = 2,  // it was dropped (timeout or kick): flagged neutral input from an agreed frame
};

enum class SessionPhase : std::uint8_t { Synchronizing, Transferring, Running, Failed };
const char* phase_name(SessionPhase p);

struct AdvanceResult {
    bool advanced = false;             // false: stalled (window full, or lockstep waiting)
    std::uint32_t frame = 0;           // the displayed frame after this call
    std::uint32_t rollback_depth = 0;  // frames resimulated first (0: no rollback)
    int wait_frames = 0;               // time sync: skip this many ticks to let peers catch up
    int blocking_player = -1;          // when stalled: the remote player whose input is missing
    std::uint64_t resim_ns = 0;        // cpu time of the rollback, if any
    std::uint64_t forward_ns = 0;      // cpu time of the forward step, if any
    // Time sync for real-time loops: lengthen the next tick by this many parts per million
    // (0..100,000: 2 % per frame ahead) so peers behind catch up without a visible skip. wait_frames is the same advice
    // as whole ticks, for virtual-time loops.
    int tick_stretch_ppm = 0;
};

// One datagram a session wants sent (poll()), addressed by peer id.
struct Datagram {
    PlayerId peer = 0;
    std::vector<std::uint8_t> bytes;
    // Snapshot-transfer messages: a transport with a reliable channel should use it (the
    // session re-asks what is lost anyway, so an unreliable one works too). Hellos and welcomes
    // are never marked: resent until answered, they carry the round trip's stamp.
    bool reliable = false;
};

// ---- what a session counts about itself (stats()) ----

// Nanoseconds from any monotonic origin; used for telemetry only (the configs' cpu_clock).
using CpuClock = std::function<std::uint64_t()>;

struct PeerStats {
    std::uint64_t packets_sent = 0, bytes_sent = 0;
    std::uint64_t packets_received = 0, bytes_received = 0;
    std::uint64_t malformed_packets = 0;  // failed to decode or broke the protocol
    std::uint64_t ignored_packets = 0;    // well-formed but useless (after an error, stale)
    bool error = false;                   // sticky: too many malformed packets
    std::uint64_t mispredictions = 0;     // confirmed inputs that differed from the one simulated
    std::uint64_t checksum_matches = 0;
    std::uint64_t checksum_mismatches = 0;
    std::uint64_t relay_disagreements = 0;  // its relayed inputs that contradicted their owner's
    std::uint64_t rtt_us = 0;             // smoothed; 0 until measured
    std::int32_t frame_advantage_x100 = 0;  // mean over the time-sync window, frames * 100
};

struct SessionStats {
    std::uint64_t ticks = 0;              // advance() calls
    std::uint64_t frames_advanced = 0;    // forward steps
    std::uint64_t stall_ticks = 0;        // advance() calls that could not step (window full)
    std::uint64_t stall_time_us = 0;      // virtual time from the first stalled tick to the next step
    std::uint64_t rollbacks = 0;
    std::uint64_t resimulated_frames = 0;
    std::uint32_t max_rollback_depth = 0;
    std::vector<std::uint64_t> rollback_depth_histogram;  // [depth], size W + 1
    std::uint64_t resim_ns = 0;           // loading and resimulating
    std::uint64_t forward_ns = 0;         // forward steps with their saves
    std::uint64_t predicted_inputs = 0;   // remote player-frames simulated with a guess
    std::uint64_t dropped_local_inputs = 0;  // after a shorter input delay caught up
    std::uint64_t oversized_states = 0;   // saves whose saved_size() exceeded state_size() (session fails)
    std::uint64_t bad_local_inputs = 0;   // advance() given the wrong number of bytes (tick skipped)
    std::uint64_t time_sync_waits = 0, time_sync_wait_frames = 0;
    std::uint64_t desyncs = 0;            // peers found desynced
    std::uint64_t bytes_sent = 0, bytes_received = 0, packets_sent = 0, packets_received = 0;
    std::uint64_t malformed_packets = 0;
    std::uint64_t unknown_peer_packets = 0;
    // A peer voted gone a running slot (this one's included) that this session did not vote
    // gone itself: counted as that peer's vote, never obeyed alone (issue 21: one forged slot
    // table dropped any player). An honest vote that comes just before this session's own
    // timeout is counted here too.
    std::uint64_t drop_votes_unheeded = 0;
    std::vector<PeerStats> peers;         // by player id; the local slot stays zero
};

}  // namespace lockroll::rollback
