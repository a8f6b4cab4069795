// The rollback decision and the frame loop: which inputs a frame is simulated with, when the
// window is full, and when and how far to roll back.
//
// Contract
//  - Prediction: a frame whose input for some player is not confirmed yet is simulated with the
//    predictor's guess, and the guess is remembered per (player, frame).
//  - Rollback: when a confirmed input arrives for a frame already simulated and differs from
//    what that frame used, the rollback target becomes min(target, that frame). The minimum over
//    every player and every arrival is kept until rollback_if_needed() runs, so no needed
//    rollback is ever dropped or postponed, whatever order several players' late inputs arrive
//    in (the 3+ player bug of GGPO/GGRS). rollback_if_needed() loads the saved state of the
//    target and resimulates to the displayed frame before anything else happens; the session
//    calls it first thing in every tick, so a corrected frame is what gets shown next.
//  - Window: with prediction window W, frame f is simulated only if every remote input for
//    frames < f - W + 1 is confirmed, i.e. at most W simulated frames rest on guesses. W = 0 is
//    lockstep: a frame runs only when all its inputs are confirmed, so there is never a guess
//    and never a rollback. A full window stalls (the caller waits) instead of advancing.
//  - Confirmation: frame n is confirmed when every input of frames < n is confirmed and it has
//    been simulated with them; confirm_next() hands out frames strictly in order, each once.
//  - Saved states: every simulated frame is saved in a ring of W + 1 + evidence_frames slots, so
//    a rollback target (never older than the oldest unconfirmed input) is always there, and
//    confirmed frames stay a while as desync evidence.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/events.h>
#include "rollback/input_queue.h"
#include "rollback/predictor.h"
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/simulation.h>
#include "rollback/snapshot_ring.h"
#include "rollback/snapshot_transfer.h"

namespace lockroll::rollback {

// CpuClock (telemetry only): rollback/session_types.h.

struct SyncConfig {
    int players = 2;
    PlayerId local_player = 0;
    std::size_t input_size = 1;
    int prediction_window = 8;
    int evidence_frames = 64;
    std::uint32_t input_capacity = 1024;  // frames per input queue, a power of two
    std::uint32_t retain_frames = 0;      // inputs kept this far behind the confirmed frame
    // A relay client: the server confirms every stream, the local slot's too (it may replace a
    // late input). Every queue is then filled by add_remote_input(), add_local_input() is not
    // used, the window counts the local queue like the others, and the local slot's guess is the
    // predictor's (the relay session's predictor answers with the input it sent).
    bool all_streams_remote = false;
};

class Sync {
public:
    // The simulation must be at its initial state (it is saved as frame 0). observer may be null.
    Sync(const SyncConfig& config, Simulation& sim, Predictor& predictor, SessionObserver* observer,
         SessionStats& stats, CpuClock cpu_clock);

    std::uint32_t frame() const { return frame_; }                    // displayed frame
    std::uint32_t confirmed_frame() const { return confirmed_frame_; }  // newest handed out
    const InputQueue& queue(PlayerId p) const { return queues_[p]; }
    std::span<const InputQueue> queues() const { return queues_; }
    int players() const { return config_.players; }
    std::size_t input_size() const { return config_.input_size; }
    int prediction_window() const { return config_.prediction_window; }
    // Mid-game switch between rollback and lockstep: 0 <= frames <= the window this Sync was
    // built with (its snapshot ring holds that many). Lowering it stalls until the frames on
    // guesses are confirmed; frames already simulated on guesses may still roll back.
    void set_prediction_window(int frames);
    bool rollback_pending() const { return pending_.has_value(); }

    // Gives the local player's input to max(frame() + delay, min_frame). When that frame already
    // has an input (the delay just shrank, or the last tick stalled) it is not used: false; sent
    // inputs never change. When the delay grew, the frames in between repeat the previous input.
    // min_frame lets a joiner that is still catching up send inputs for the frames the match is
    // at, not the ones it shows. Precondition: !local_queue_full(delay).
    bool add_local_input(std::span<const std::uint8_t> input, int delay, std::uint32_t min_frame = 0);
    // A confirmed input of another slot (its player's, or relayed); counts and schedules a
    // rollback on a misprediction (input bytes or absent flag).
    InputQueue::Add add_remote_input(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> input,
                                     bool absent = false);
    // The owner's input of `frame` replaces a relayed one that differs (InputQueue::
    // replace_confirmed): only while no confirmed frame rests on it (frame >= confirmed_frame()),
    // else false and nothing changes. A frame already simulated with other bytes is rolled back
    // like a misprediction.
    bool replace_remote_input(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> input);

    // Frames the queue of `player` must keep beyond confirmation: for the local queue the
    // oldest input a peer has not acknowledged (resends), for any queue the oldest a peer being
    // relayed to still lacks. Inputs before min(confirmed_frame(), keep) are discarded.
    void set_keep_from(PlayerId player, std::uint32_t frame);
    // Backwards-compatible name for the local queue's keep_from.
    void set_local_resend_floor(std::uint32_t frame) { set_keep_from(config_.local_player, frame); }

    // Replaces everything with a snapshot of `frame` (a joiner's or a recovering peer's start):
    // the simulation loads `state`, every queue restarts at `frame`, `frame` becomes displayed
    // and confirmed. Empty string on success; otherwise why (and nothing changed).
    std::string restart_at(std::uint32_t frame, std::span<const std::uint8_t> state);
    InputQueue& mutable_queue(PlayerId p) { return queues_[p]; }
    // Snapshot exchange (rollback/snapshot_transfer.h), the provider's side: what a transfer of
    // confirmed frame `frame` carries, its saved state and (with_streams) every input each queue
    // holds from `frame` on. False when the ring or a queue no longer holds that frame.
    bool transfer_contents(std::uint32_t frame, bool with_streams, TransferContents& out) const;
    // The newcomer's side: restart_at(t.frame, t.state), then every queue refilled with the
    // transfer's inputs and, after them, the confirmed inputs this Sync already held past them
    // (confirmed, so still valid). Empty string on success; otherwise why (nothing changed).
    std::string load_transfer(const TransferContents& t);

    // True when frame() may not advance: the window is full (in lockstep: an input of frame()
    // is missing), or the local queue cannot hold frame() + delay yet.
    bool must_wait(int delay) const;
    // The local queue cannot take frame() + delay before peers acknowledge older inputs.
    bool local_queue_full(int delay) const;
    // The remote player whose missing input holds the window (for diagnostics); -1 if none.
    int blocking_player() const;

    // Loads and resimulates if a rollback is pending; returns its depth (0 if none).
    std::uint32_t rollback_if_needed();
    // Simulates frame() forward once. Precondition: !must_wait(delay) and add_local_input done.
    void step_forward();

    // Frames [0, inputs_complete()) have every slot's input confirmed.
    std::uint32_t inputs_complete() const { return all_confirmed_inputs(); }
    // Newest frame that can be confirmed now (no pending rollback may exist).
    std::uint32_t confirmable_frame() const;
    // Confirms confirmed_frame() + 1 (precondition: < confirmable_frame()); the spans point into
    // buffers valid until the next call.
    FrameConfirmed confirm_next();

    std::optional<std::span<const std::uint8_t>> saved_state(std::uint32_t frame) const { return ring_.find(frame); }
    const SnapshotRing& ring() const { return ring_; }
    std::uint64_t initial_checksum() const { return initial_checksum_; }

    // Every time frame `frame` is produced by a step (forward or resimulated), flip the bit.
    // Empty string on success, else why not (already simulated, no such body / field / bit).
    std::string add_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit);

private:
    void simulate_one(bool resimulation);
    std::uint32_t all_confirmed_inputs() const;
    std::uint32_t remote_confirmed_inputs() const;
    void update_floors();
    std::uint32_t retained_floor() const;  // confirmed_frame() - retain_frames, at least 0

    struct Fault {
        std::uint32_t frame;
        std::uint32_t body_id;
        int field;
        int bit;
    };

    SyncConfig config_;
    int max_window_;
    Simulation& sim_;
    Predictor& predictor_;
    SessionObserver* observer_;
    SessionStats& stats_;
    CpuClock cpu_clock_;
    std::vector<InputQueue> queues_;
    SnapshotRing ring_;
    std::uint32_t frame_ = 0;
    std::uint32_t highest_simulated_ = 0;
    std::uint32_t confirmed_frame_ = 0;
    std::vector<std::uint32_t> keep_from_;  // per queue, see set_keep_from
    std::optional<std::uint32_t> pending_;
    std::uint64_t initial_checksum_ = 0;
    std::vector<std::uint8_t> frame_inputs_;    // players * input_size, reused every step
    std::vector<InputStatus> frame_status_;     // players, reused every step
    std::vector<std::uint8_t> confirm_inputs_;  // same, for confirm_next
    std::vector<std::uint8_t> scratch_input_;
    std::vector<Fault> faults_;
};

}  // namespace lockroll::rollback
