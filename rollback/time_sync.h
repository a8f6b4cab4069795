// Keeping clients from running ahead of each other, from frame advantage (as GGPO does).
//
// A client that runs ahead of a peer makes that peer's inputs arrive "late" for it: it predicts
// more, rolls back deeper, and stalls when its window fills, while the peer behind never has to.
// Each side estimates its local advantage (peer's frame now - own frame, using the peer's last
// reported frame plus half a round trip) and sends it; the peer's estimate of the same gap from
// the other side arrives in its messages. Half the difference of the two averages is how many
// frames this client is ahead, with the one-way latency estimates cancelling out.
//
// Integer arithmetic over a sliding window; no clock is read here.
#pragma once

#include <cstdint>
#include <vector>

namespace lockroll::rollback {

// The longest a tick may be stretched to slow a client that runs ahead (AdvanceResult's
// tick_stretch_ppm), for the P2P and relay sessions alike. A proportional controller settles
// where the stretch equals the clock-rate difference, so the cap is the largest difference it
// can follow: 5 % (GGRS's figure) was too little for one clock 1 % fast against one 5 % slow
// (6.3 %), whose fast peer then stalled now and then; at 10 % it settles a few frames ahead and
// never stalls (Lifecycle.StretchedTicksFollowClocksSixPercentApart,
// RelayMatch.ClockEightPercentFastKeepsItsLead).
inline constexpr int kMaxTickStretchPpm = 100'000;

class TimeSync {
public:
    explicit TimeSync(int window);

    // One sample per tick: local = peer frame - own frame (estimated here), remote = the peer's
    // own estimate of own frame - peer frame, as it last reported.
    void add_sample(std::int32_t local_advantage, std::int32_t remote_advantage);
    void clear();

    bool full() const { return count_ == samples_local_.size(); }
    int samples() const { return static_cast<int>(count_); }
    // Frames this client is ahead of the peer, times 100 (0 when no samples).
    std::int32_t frames_ahead_x100() const;
    // Mean local advantage, times 100 (positive: the peer is ahead of us).
    std::int32_t local_advantage_x100() const;
    // Frames to wait so that the peer catches up: frames_ahead rounded, once the window is full
    // and the gap is at least min_frames; otherwise 0.
    int recommended_wait(int min_frames) const;

private:
    std::vector<std::int32_t> samples_local_, samples_remote_;
    std::size_t next_ = 0, count_ = 0;
    std::int64_t sum_local_ = 0, sum_remote_ = 0;
};

}  // namespace lockroll::rollback
