#include "rollback/frame_pacing.h"

#include <algorithm>

#include "rollback/time_sync.h"

namespace lockroll::rollback {

void FramePacing::sample(std::span<PeerLink> links, const Paces& paces, std::uint32_t frame, int input_delay,
                         std::uint64_t now_us, std::span<std::int32_t> local_advantage, std::span<PeerStats> stats) const {
    const std::int64_t bound = advantage_bound(input_delay);
    for (std::size_t p = 0; p < links.size(); ++p) {
        PeerLink& link = links[p];
        if (!paces(static_cast<PlayerId>(p)) || !link.has_remote_frame) continue;
        const std::int64_t adv = link.estimated_frame(now_us, config_.interrupt_us, config_.tick_rate) - std::int64_t{frame};
        local_advantage[p] = static_cast<std::int32_t>(std::clamp<std::int64_t>(adv, -bound, bound));
        link.time_sync().add_sample(local_advantage[p], link.remote_advantage);
        stats[p].frame_advantage_x100 = link.time_sync().local_advantage_x100();
        stats[p].rtt_us = link.rtt_us();
    }
}

std::int32_t FramePacing::frames_ahead_x100(std::span<const PeerLink> links, const Paces& paces) const {
    std::int32_t ahead = 0;
    for (std::size_t p = 0; p < links.size(); ++p)
        if (paces(static_cast<PlayerId>(p))) ahead = std::max(ahead, links[p].time_sync().frames_ahead_x100());
    return ahead;
}

std::int32_t FramePacing::behind(std::span<const PeerLink> links, const Paces& paces, std::uint32_t frame,
                                 std::uint64_t now_us) const {
    std::int64_t most = 0;
    for (std::size_t p = 0; p < links.size(); ++p) {
        const PeerLink& link = links[p];
        if (!paces(static_cast<PlayerId>(p)) || !link.has_remote_frame) continue;
        most = std::max(most, link.estimated_frame(now_us, config_.interrupt_us, config_.tick_rate) - std::int64_t{frame});
    }
    return static_cast<std::int32_t>(std::min<std::int64_t>(most, 1 << 30));
}

int FramePacing::recommend_wait(std::span<PeerLink> links, const Paces& paces, std::uint32_t frame, int input_delay) {
    if (frame < next_window_frame_) return 0;
    int wait_frames = 0;
    for (std::size_t p = 0; p < links.size(); ++p)
        if (paces(static_cast<PlayerId>(p)))
            wait_frames = std::max(wait_frames, links[p].time_sync().recommended_wait(config_.time_sync_min_frames));
    wait_frames = std::min(wait_frames, input_delay + config_.prediction_window + 2);
    if (wait_frames <= 0) return 0;
    for (auto& link : links) link.time_sync().clear();
    next_window_frame_ = frame + static_cast<std::uint32_t>(config_.time_sync_window);
    return wait_frames;
}

int FramePacing::tick_stretch_ppm(std::int32_t ahead_x100) {
    // time_sync.h says why at most 10 %. Equal clocks stay within a frame and barely stretch.
    if (ahead_x100 <= 50) return 0;
    return static_cast<int>(std::min<std::int64_t>(std::int64_t{ahead_x100} * 200, kMaxTickStretchPpm));
}

}  // namespace lockroll::rollback
