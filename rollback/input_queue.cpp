#include "rollback/input_queue.h"

#include <algorithm>
#include <stdexcept>

namespace lockroll::rollback {

InputQueue::InputQueue(std::size_t input_size, std::uint32_t capacity)
    : input_size_(input_size),
      capacity_(capacity),
      confirmed_(std::size_t{capacity} * input_size),
      used_(std::size_t{capacity} * input_size),
      used_tag_(capacity, 0),
      absent_(capacity, 0),
      used_absent_(capacity, 0) {
    if (input_size == 0) throw std::invalid_argument("input_size must be at least 1");
    if (capacity < 2 || (capacity & (capacity - 1)) != 0)
        throw std::invalid_argument("input queue capacity must be a power of two >= 2");
}

void InputQueue::discard_before(std::uint32_t frame) { floor_ = std::max(floor_, frame); }

InputQueue::Add InputQueue::add_confirmed(std::uint32_t frame, std::span<const std::uint8_t> input, bool absent) {
    if (input.size() != input_size_) return Add::Conflict;
    if (frame < confirmed_count_) {
        if (frame < floor_) return Add::TooOld;
        const std::uint8_t* have = confirmed_.data() + slot(frame);
        return std::equal(input.begin(), input.end(), have) && confirmed_absent(frame) == absent ? Add::Duplicate
                                                                                                 : Add::Conflict;
    }
    if (frame > confirmed_count_) return Add::Gap;
    if (std::uint64_t{frame} >= std::uint64_t{floor_} + capacity_) return Add::TooFarAhead;
    std::copy(input.begin(), input.end(), confirmed_.begin() + static_cast<std::ptrdiff_t>(slot(frame)));
    absent_[frame & (capacity_ - 1)] = absent ? 1 : 0;
    last_.assign(input.begin(), input.end());
    last_absent_ = absent;
    ++confirmed_count_;
    return Add::Stored;
}

bool InputQueue::replace_confirmed(std::uint32_t frame, std::span<const std::uint8_t> input) {
    if (input.size() != input_size_ || frame < floor_ || frame >= confirmed_count_) return false;
    std::copy(input.begin(), input.end(), confirmed_.begin() + static_cast<std::ptrdiff_t>(slot(frame)));
    absent_[frame & (capacity_ - 1)] = 0;
    if (frame + 1 == confirmed_count_) {
        last_.assign(input.begin(), input.end());
        last_absent_ = false;
    }
    return true;
}

void InputQueue::restart_at(std::uint32_t frame) {
    confirmed_count_ = frame;
    floor_ = frame;
    std::fill(used_tag_.begin(), used_tag_.end(), 0u);
    last_.clear();
    last_absent_ = false;
}

std::span<const std::uint8_t> InputQueue::confirmed(std::uint32_t frame) const {
    return {confirmed_.data() + slot(frame), input_size_};
}

std::span<const std::uint8_t> InputQueue::last_confirmed() const { return last_; }

InputQueue::Run InputQueue::copy_confirmed(std::uint32_t from, std::uint32_t max, std::vector<std::uint8_t>& out) const {
    Run r;
    r.first = std::max(from, floor_);
    r.count = confirmed_count_ > r.first ? std::min(confirmed_count_ - r.first, max) : 0;
    out.resize(std::size_t{r.count} * input_size_);
    for (std::uint32_t k = 0; k < r.count; ++k) {
        const auto in = confirmed(r.first + k);
        std::copy(in.begin(), in.end(), out.begin() + static_cast<std::ptrdiff_t>(std::size_t{k} * input_size_));
    }
    return r;
}

void InputQueue::set_used(std::uint32_t frame, std::span<const std::uint8_t> input, bool absent) {
    std::copy(input.begin(), input.end(), used_.begin() + static_cast<std::ptrdiff_t>(slot(frame)));
    used_tag_[frame & (capacity_ - 1)] = frame + 1;
    used_absent_[frame & (capacity_ - 1)] = absent ? 1 : 0;
}

std::optional<std::span<const std::uint8_t>> InputQueue::used(std::uint32_t frame) const {
    if (used_tag_[frame & (capacity_ - 1)] != frame + 1) return std::nullopt;
    return std::span<const std::uint8_t>(used_.data() + slot(frame), input_size_);
}

}  // namespace lockroll::rollback
