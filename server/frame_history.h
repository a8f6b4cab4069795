// FrameHistory: a room's confirmed input sets, oldest first, as fixed-size records in one flat
// ring. It grows by doubling up to max_frames (a short match never pays for ten minutes), then
// drops the oldest record for each new one. One record is players flags + players x input_size
// bytes: a 2-player room with 3-byte inputs keeps 10 minutes at 60 Hz in 288 KB.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::server {

class FrameHistory {
public:
    FrameHistory(std::size_t record_bytes, std::size_t max_frames);

    std::size_t size() const { return count_; }
    std::size_t record_bytes() const { return record_; }
    // A new newest record, zeroed (the oldest is dropped when max_frames are held).
    std::span<std::uint8_t> push();
    // Record i, 0 = the oldest held; i < size().
    std::span<const std::uint8_t> at(std::size_t i) const {
        const std::size_t slot = (head_ + i) % capacity_;
        return {buf_.data() + slot * record_, record_};
    }
    std::size_t bytes_reserved() const { return buf_.capacity(); }

private:
    std::size_t record_;
    std::size_t max_;
    std::size_t capacity_ = 0;  // records allocated
    std::size_t head_ = 0;      // slot of the oldest
    std::size_t count_ = 0;
    std::vector<std::uint8_t> buf_;
};

}  // namespace lockroll::server
