// SessionConfig: what a peer-to-peer Session is told at construction (rollback/session.h), and
// validate(), which names the first unusable field. Split from the session so that the builder
// (net/session_builder) and tools check a config without a session, and the session's file
// holds only its state machine.
//
// Contract: validate() throws std::invalid_argument "session config: FIELD ..." for the first
// field that is out of range or inconsistent with another, and nothing else; a config it passes
// constructs a session (as far as the config goes: the simulation may still refuse).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <lockroll/rollback/player_id.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/telemetry.h>

namespace lockroll::rollback {

// A view of two running players has no strict majority of the other voter: what then.
enum class TwoPlayerRule : std::uint8_t {
    PlayOnAlone,  // either one's vote drops the other: each survivor plays on alone (the default)
    NoDrop,       // nobody is dropped: the one that lost the other reports Partitioned and waits
};
const char* two_player_rule_name(TwoPlayerRule r);

// Two peers disagree and neither is a majority: whose state survives.
enum class DesyncKeep : std::uint8_t { LowestSlot, HighestSlot };

struct SessionConfig {
    int players = 2;                   // 1..kMaxPlayers
    PlayerId local_player = 0;
    std::size_t input_size = 3;        // bytes per player-frame, 1..kMaxInputSize (64)
    int tick_rate = 60;                // Hz; converts times to frames for time sync
    int input_delay = 2;               // frames; set_input_delay() changes it mid-game
    int prediction_window = 8;         // W; 0 = lockstep
    int checksum_interval = 1;         // K: frames whose number is a multiple of K are compared
    int checksum_repeats = 2;          // the newest checksum rides on this many messages
    int evidence_frames = 64;          // confirmed states kept beyond the rollback window
    int max_bad_packets = 8;           // malformed datagrams before a peer is ignored for good
    std::uint32_t input_capacity = 1024;  // frames per input queue (power of two)
    int time_sync_window = 60;         // ticks averaged per recommendation
    int time_sync_min_frames = 2;      // recommend waiting only when this many frames ahead
    int time_sync_every = 8;           // time-sync fields ride on every Nth message
    std::uint64_t query_resend_us = 100000;  // desync narrowing: re-ask after this long
    int max_replies_per_poll = 16;     // per peer: answers beyond this are dropped (re-asked)
    CpuClock cpu_clock;                // telemetry only (CPU per tick, rollback cost); none: 0

    // ---- lifecycle (docs/sessions.md) ----
    // false: every slot not in absent_slots is running from frame 0 with no handshake (the
    // in-process harness); true: hello/welcome and an RTT sync phase come first (real networks).
    bool handshake = false;
    Role role = Role::Player;          // Joiner / Spectator: start from a peer's snapshot
    std::uint64_t match_id = 0;
    std::uint64_t scene_checksum = 0;  // 0: the simulation's initial-state checksum
    std::uint64_t absent_slots = 0;    // bit s: nobody plays slot s at frame 0
    int max_spectators = 0;            // peer ids players .. players + max_spectators - 1
    int sync_roundtrips = 5;           // hello/welcome round trips before frame 0
    bool auto_input_delay = false;     // input delay from the sync phase's RTT
    std::uint64_t hello_resend_us = 50000;
    std::uint64_t interrupt_us = 750000;     // silence before a peer is reported interrupted
    std::uint64_t disconnect_us = 5000000;   // silence before it is dropped (0: never)
    std::uint64_t transfer_resend_us = 250000;  // snapshot offers and chunks re-asked after this
    int transfer_window = 32;          // chunks in flight per transfer
    std::uint32_t max_snapshot_bytes = 64u << 20;
    int max_recoveries = 0;            // desync recoveries before giving up (0: never recover)
    DesyncKeep two_player_keep = DesyncKeep::LowestSlot;
    // Two running processes left in the view have no majority of the other: PlayOnAlone (either
    // one's silence timeout drops the other, and each side plays on alone) or NoDrop (nobody is
    // dropped: the one that lost the other reports Partitioned and waits for it). Every peer
    // must pass the same rule. Three or more: a strict majority of the view, always.
    TwoPlayerRule two_player_rule = TwoPlayerRule::PlayOnAlone;
    int relay_lag = 0;                 // relay a stream to a peer this far behind (0: auto)
    // Names this process in its hellos (0: taken from the first now_us this session sees, which
    // differs between a process and its restarted successor).
    std::uint64_t incarnation = 0;

    // ---- several local players per process (couch + online) ----
    // Empty: every slot is its own process (peer id == slot). Otherwise one entry per slot:
    // slot_hosts[s] is the slot whose process plays s, always the lowest slot of that process
    // (slot_hosts[s] <= s, and a host hosts itself). Every peer passes the same table. A hosted
    // slot (a "guest": slot_hosts[s] != s) has no peer id or connection of its own: its host's
    // session authors its stream (confirmed at once, sent to everyone as stream blocks, like the
    // owner's neutral inputs for absent slots), and it is dropped together with its host. This
    // session plays local_player plus every slot whose host is local_player (local_slots()).
    // Joiners cannot host guests yet.
    std::vector<PlayerId> slot_hosts;
};

// Throws std::invalid_argument naming the field when a config is unusable.
void validate(const SessionConfig& config);

}  // namespace lockroll::rollback
