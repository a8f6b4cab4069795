// A rollback/lockstep session: one client's side of an N-player peer-to-peer game.
//
// The session is a pure state machine. It reads no clock (time comes in as now_us, a caller's
// monotonic microsecond count, virtual in the harness), owns no socket (datagrams go out through
// poll() and come in through receive(), addressed by player id), and drives any Simulation.
// So the harness can run N sessions in one process in virtual time, bit-reproducibly, and the
// same code can sit on ENet.
//
// Driving it, per client:
//
//     Session s(config, simulation, &observer);       // observer may be nullptr
//     every tick (1 / tick_rate of that client's clock):
//         for each datagram that arrived:  s.receive(from_player, bytes, now_us);
//         AdvanceResult r = s.advance(local_input_bytes, now_us);   // maybe rolls back, steps
//         s.poll(now_us, outgoing);        // append datagrams; hand each to the transport
//         if (r.wait_frames > 0) skip the next r.wait_frames ticks (time sync) but keep
//             calling receive() and poll() in them.
//
// Semantics (see sync.h for the frame loop, desync_detector.h for alerts):
//  - Frame n is the state after n steps; advance() shows frame() afterwards.
//  - Rollback mode (prediction_window W >= 1): the local input given to advance() belongs to
//    frame() + input_delay and is applied at once; missing remote inputs are predicted; a late
//    input that contradicts a prediction triggers a rollback at the start of the next advance(),
//    before the next frame is shown. With W frames resting on guesses, advance() stalls
//    (returns advanced = false) instead of guessing further.
//  - Lockstep (W = 0): a frame runs only when every input for it is confirmed; never predicts,
//    never rolls back. Choose input_delay >= one-way latency + jitter (in frames) and it runs at
//    the full tick rate (pipelined lockstep).
//  - Inputs travel unreliably and redundantly: each poll() sends every peer all local inputs it
//    has not acknowledged, plus an ack, so loss costs latency, never correctness.
//  - Confirmed-frame checksums ride along every checksum_interval frames; a mismatch fires
//    SessionObserver::on_desync and then a DesyncReport naming the first differing body/field.
//  - Malformed datagrams are counted; after max_bad_packets the peer is ignored for good.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/desync_detector.h"
#include "rollback/events.h"
#include "rollback/peer_link.h"
#include "rollback/player_id.h"
#include "rollback/predictor.h"
#include "rollback/protocol.h"
#include "rollback/simulation.h"
#include "rollback/sync.h"
#include "rollback/telemetry.h"

namespace lockroll::rollback {

struct SessionConfig {
    int players = 2;                   // 1..kMaxPlayers
    PlayerId local_player = 0;
    std::size_t input_size = 3;        // bytes per player-frame, 1..kMaxInputSize
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
    CpuClock cpu_clock;                // telemetry only; default std::chrono::steady_clock
};

// Throws std::invalid_argument naming the field when a config is unusable.
void validate(const SessionConfig& config);

struct Datagram {
    PlayerId peer = 0;
    std::vector<std::uint8_t> bytes;
};

struct AdvanceResult {
    bool advanced = false;             // false: stalled (window full, or lockstep waiting)
    std::uint32_t frame = 0;           // the displayed frame after this call
    std::uint32_t rollback_depth = 0;  // frames resimulated first (0: no rollback)
    int wait_frames = 0;               // time sync: skip this many ticks to let peers catch up
    int blocking_player = -1;          // when stalled: the remote player whose input is missing
    std::uint64_t resim_ns = 0;        // cpu time of the rollback, if any
    std::uint64_t forward_ns = 0;      // cpu time of the forward step, if any
};

class Session {
public:
    // The simulation must be in its initial state and outlive the session, as must the
    // observer and predictor (nullptr: none / repeat-last). Throws std::invalid_argument for a
    // bad config.
    Session(const SessionConfig& config, Simulation& simulation, SessionObserver* observer = nullptr,
            Predictor* predictor = nullptr);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    // A datagram from player `from`. Never throws or asserts on its content.
    void receive(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us);
    // One tick: rolls back if needed, then steps once unless the window is full. local_input
    // (input_size bytes) becomes the input of frame() + input_delay() if that frame has none yet
    // -- also on a stalled tick, since in lockstep both sides wait for each other's input of the
    // same frame -- and is otherwise not used.
    AdvanceResult advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us);
    // Appends the datagrams to send now: one input message per healthy peer, plus desync
    // queries and replies. Call every tick, stalled or not (resends are what beat loss).
    void poll(std::uint64_t now_us, std::vector<Datagram>& out);

    // Takes effect for the next local input. Growing repeats the last input into the gap;
    // shrinking drops inputs until the delay has caught up (sent inputs never change).
    void set_input_delay(int frames);
    // Fault injection: every time frame `frame` is produced by a step on this client, flip
    // `bit` of `field` of body `body_id`. Empty string on success, else why not (the frame is
    // already simulated, or the simulation has no such body/field).
    std::string inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit);

    const SessionConfig& config() const { return config_; }
    std::uint32_t frame() const { return sync_->frame(); }
    std::uint32_t confirmed_frame() const { return sync_->confirmed_frame(); }
    int input_delay() const { return input_delay_; }
    bool stalled() const { return stalled_since_.has_value(); }
    // Checksum of a confirmed frame, while remembered.
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const {
        return detector_->local_checksum(frame);
    }
    // Saved state of a frame while the ring holds it (confirmed frames are final).
    std::optional<std::span<const std::uint8_t>> saved_state(std::uint32_t frame) const {
        return sync_->saved_state(frame);
    }
    // Stats are updated in place; peers[p].rtt_us / frame_advantage_x100 are refreshed by
    // advance().
    const SessionStats& stats() const { return stats_; }
    bool peer_error(PlayerId p) const { return links_[p].error(); }
    // The first of our input frames peer p has not acknowledged: p holds our inputs of every
    // frame before it (so once it is > n and p has everyone else's, p can confirm frame n + 1).
    std::uint32_t peer_ack(PlayerId p) const { return links_[p].remote_ack; }
    bool desynced(PlayerId p) const { return detector_->desynced(p); }
    // Frames this client is ahead of the slowest peer (x100), averaged over the window.
    std::int32_t frames_ahead_x100() const;

private:
    void handle_input(PlayerId from, std::uint64_t now_us);
    void malformed(PlayerId from, const char* why);
    void confirm_frames();
    void sample_time_sync(std::uint64_t now_us);
    void refresh_resend_floor();
    std::uint32_t checkpoint() const;

    SessionConfig config_;
    Simulation& sim_;
    SessionObserver* observer_;
    std::unique_ptr<Predictor> default_predictor_;
    SessionStats stats_;
    std::unique_ptr<Sync> sync_;
    std::unique_ptr<DesyncDetector> detector_;
    std::vector<PeerLink> links_;
    std::vector<std::int32_t> local_advantage_;   // per peer, latest estimate (frames)
    std::vector<int> replies_this_poll_;
    std::vector<Datagram> pending_out_;
    int input_delay_;
    std::optional<std::uint64_t> stalled_since_;
    std::uint32_t next_time_sync_frame_ = 0;
    std::vector<std::uint64_t> first_sent_us_;   // by local input frame & (capacity - 1)
    std::vector<std::uint32_t> first_sent_tag_;  // frame + 1
    // decode scratch, reused
    InputMessage in_msg_;
    QueryMessage query_msg_;
    ReplyMessage reply_msg_;
    InputMessage out_msg_;
    std::vector<std::pair<PlayerId, QueryMessage>> queries_;
};

}  // namespace lockroll::rollback
