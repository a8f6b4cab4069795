// Counters a session keeps about itself, for the harness's reports.
//
// Times: *_ns are CPU-side durations measured with the session's cpu clock (telemetry only:
// nothing the session decides depends on them); *_us are virtual times from the now_us values
// the caller passes in.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace lockroll::rollback {

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

// The stall bookkeeping both sessions share: a tick that cannot step starts or continues a
// stall, the next step ends it and adds its length to stall_time_us. Time comes from the caller
// and need not be monotonic: a stall never adds a negative (wrapped) length.
class StallTracker {
public:
    void stalled(std::uint64_t now_us, SessionStats& s) {
        ++s.stall_ticks;
        if (!since_) since_ = now_us;
    }
    // A step: true when it ended a stall.
    bool stepped(std::uint64_t now_us, SessionStats& s) {
        if (!since_) return false;
        s.stall_time_us += now_us >= *since_ ? now_us - *since_ : 0;
        since_.reset();
        return true;
    }
    bool stalled() const { return since_.has_value(); }

private:
    std::optional<std::uint64_t> since_;
};

}  // namespace lockroll::rollback
