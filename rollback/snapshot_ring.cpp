#include "rollback/snapshot_ring.h"

#include <algorithm>
#include <stdexcept>

namespace lockroll::rollback {

SnapshotRing::SnapshotRing(std::size_t slots, std::size_t state_size)
    : state_size_(state_size), data_(slots * state_size), tags_(slots, 0), used_(slots, state_size) {
    if (slots == 0) throw std::invalid_argument("snapshot ring needs at least one slot");
}

std::span<std::uint8_t> SnapshotRing::slot_for(std::uint32_t frame) {
    const std::size_t i = frame % tags_.size();
    tags_[i] = std::uint64_t{frame} + 1;
    used_[i] = state_size_;
    return {data_.data() + i * state_size_, state_size_};
}

void SnapshotRing::set_used(std::uint32_t frame, std::size_t used) {
    const std::size_t i = frame % tags_.size();
    if (tags_[i] == std::uint64_t{frame} + 1) used_[i] = std::min(used, state_size_);
}

std::optional<std::span<const std::uint8_t>> SnapshotRing::find(std::uint32_t frame) const {
    const std::size_t i = frame % tags_.size();
    if (tags_[i] != std::uint64_t{frame} + 1) return std::nullopt;
    return std::span<const std::uint8_t>(data_.data() + i * state_size_, used_[i]);
}

}  // namespace lockroll::rollback
