#include "server/frame_history.h"

#include <algorithm>

namespace lockroll::server {

FrameHistory::FrameHistory(std::size_t record_bytes, std::size_t max_frames)
    : record_(std::max<std::size_t>(1, record_bytes)), max_(std::max<std::size_t>(1, max_frames)) {}

std::span<std::uint8_t> FrameHistory::push() {
    if (count_ == capacity_ && capacity_ < max_) {
        // Grow: linearise into a buffer twice the size (at most max_ records).
        const std::size_t grown = std::min(max_, std::max<std::size_t>(64, capacity_ * 2));
        std::vector<std::uint8_t> next(grown * record_, 0);
        for (std::size_t i = 0; i < count_; ++i) {
            const auto r = at(i);
            std::copy(r.begin(), r.end(), next.begin() + static_cast<std::ptrdiff_t>(i * record_));
        }
        buf_.swap(next);
        capacity_ = grown;
        head_ = 0;
    }
    std::size_t slot;
    if (count_ < capacity_) {
        slot = (head_ + count_) % capacity_;
        ++count_;
    } else {  // full at max_: the oldest goes
        slot = head_;
        head_ = (head_ + 1) % capacity_;
    }
    const std::span<std::uint8_t> rec(buf_.data() + slot * record_, record_);
    std::fill(rec.begin(), rec.end(), std::uint8_t{0});
    return rec;
}

}  // namespace lockroll::server
