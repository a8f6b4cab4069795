// FramePacing: a P2P session's pace against the other players (time sync, GGPO-style): each
// peer's frame estimated now, our advantage sampled against it every tick, at most one "wait N
// frames" per time_sync_window frames, and the same advice as a gentle tick stretch.
//
// Contract
//  - Only the peers `paces` names count (the session's live player peers); their links hold
//    the samples (PeerLink::time_sync()). No clock: now_us comes in.
//  - A peer's frame is what it last reported plus the time since then and half a round trip; a
//    peer silent for longer than interrupt_us is not assumed to have run on (its estimate stops
//    there). Advantages, ours and the peer's claim, are clipped to advantage_bound(): an honest
//    peer is never farther from us than input delay plus prediction window plus the time sync's
//    own slack, so one forged message cannot make us wait thousands of frames.
//  - recommend_wait(): from fresh samples only -- a recommendation clears every link's samples
//    and the next comes time_sync_window frames later at the earliest; never more than input
//    delay + prediction window + 2 frames.
//  - tick_stretch_ppm(): 2 % per frame ahead beyond half a frame, at most kMaxTickStretchPpm.
#pragma once

#include <cstdint>
#include <functional>
#include <span>

#include "rollback/peer_link.h"
#include "rollback/session.h"

namespace lockroll::rollback {

class FramePacing {
public:
    using Paces = std::function<bool(PlayerId)>;  // this peer's pace counts (a live player peer)

    explicit FramePacing(const SessionConfig& config) : config_(config) {}

    std::int64_t advantage_bound(int input_delay) const {
        return input_delay + config_.prediction_window + 2 * config_.time_sync_min_frames + 2;
    }
    // One sample against every pacing peer that reported its frame: local_advantage[p] and the
    // peer's stats (frame_advantage_x100, rtt_us) are refreshed.
    void sample(std::span<PeerLink> links, const Paces& paces, std::uint32_t frame, int input_delay,
                std::uint64_t now_us, std::span<std::int32_t> local_advantage, std::span<PeerStats> stats) const;
    // Frames this session is ahead of the slowest pacing peer (x100), averaged over the window.
    std::int32_t frames_ahead_x100(std::span<const PeerLink> links, const Paces& paces) const;
    // Frames the most advanced pacing peer is estimated to be ahead of `frame` now (0 if none).
    std::int32_t behind(std::span<const PeerLink> links, const Paces& paces, std::uint32_t frame,
                        std::uint64_t now_us) const;
    // Frames to wait now (0: none), once per window.
    int recommend_wait(std::span<PeerLink> links, const Paces& paces, std::uint32_t frame, int input_delay);
    static int tick_stretch_ppm(std::int32_t ahead_x100);
    // A snapshot loaded at `frame`: samples of the old timeline are void (the caller clears them).
    void restart_at(std::uint32_t frame) { next_window_frame_ = frame; }

private:
    const SessionConfig& config_;
    std::uint32_t next_window_frame_ = 0;
};

}  // namespace lockroll::rollback
