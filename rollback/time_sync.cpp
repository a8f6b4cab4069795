#include "rollback/time_sync.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace lockroll::rollback {

TimeSync::TimeSync(int window)
    : samples_local_(static_cast<std::size_t>(std::max(window, 1))),
      samples_remote_(static_cast<std::size_t>(std::max(window, 1))) {}

void TimeSync::add_sample(std::int32_t local_advantage, std::int32_t remote_advantage) {
    if (count_ == samples_local_.size()) {
        sum_local_ -= samples_local_[next_];
        sum_remote_ -= samples_remote_[next_];
    } else {
        ++count_;
    }
    samples_local_[next_] = local_advantage;
    samples_remote_[next_] = remote_advantage;
    sum_local_ += local_advantage;
    sum_remote_ += remote_advantage;
    next_ = (next_ + 1) % samples_local_.size();
}

void TimeSync::clear() {
    next_ = count_ = 0;
    sum_local_ = sum_remote_ = 0;
}

namespace {
// Sums of int32 claims fit in 64 bits; their x100 averages may not fit in 32, and a claim is a
// peer's word: saturate rather than wrap, so a larger claim never reads as a smaller one.
std::int32_t saturate(std::int64_t v) {
    return static_cast<std::int32_t>(
        std::clamp<std::int64_t>(v, std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max()));
}
}  // namespace

// ahead = (remote - local) / 2: if we are k frames ahead, local ~ -k and remote ~ +k.
std::int32_t TimeSync::frames_ahead_x100() const {
    if (count_ == 0) return 0;
    return saturate((sum_remote_ - sum_local_) * 100 / (2 * static_cast<std::int64_t>(count_)));
}

std::int32_t TimeSync::local_advantage_x100() const {
    if (count_ == 0) return 0;
    return saturate(sum_local_ * 100 / static_cast<std::int64_t>(count_));
}

int TimeSync::recommended_wait(int min_frames) const {
    if (!full()) return 0;
    const std::int32_t ahead = frames_ahead_x100();
    if (ahead < 100 * min_frames) return 0;
    return static_cast<int>((std::int64_t{ahead} + 50) / 100);
}

}  // namespace lockroll::rollback
