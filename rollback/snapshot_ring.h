// Saved states of the most recent frames, for rollback (the last W + 1) and as desync evidence
// (confirmed frames kept a while longer, so the state a checksum disagreed on still exists when
// the alert fires).
//
// Contract
//  - All memory is allocated in the constructor: slots * state_size bytes (the capacity). A
//    slot remembers how many of its bytes the saved state took (variable-size states), and
//    find() returns exactly those. Saving a frame reuses
//    the slot of frame - slots; find() says whether a frame is still held, so a caller can never
//    read a state that was overwritten under it.
//  - A slot holds whatever was saved last for that frame: after a rollback resimulates a frame,
//    its new state replaces the mispredicted one.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace lockroll::rollback {

class SnapshotRing {
public:
    SnapshotRing(std::size_t slots, std::size_t state_size);

    std::size_t slots() const { return tags_.size(); }
    std::size_t state_size() const { return state_size_; }

    // The buffer (state_size() bytes) to save `frame` into; from now on find(frame) returns its
    // first state_size() bytes, or `used` once set_used() says how many the state took.
    std::span<std::uint8_t> slot_for(std::uint32_t frame);
    void set_used(std::uint32_t frame, std::size_t used);
    std::optional<std::span<const std::uint8_t>> find(std::uint32_t frame) const;
    bool holds(std::uint32_t frame) const { return find(frame).has_value(); }

private:
    std::size_t state_size_;
    std::vector<std::uint8_t> data_;
    std::vector<std::uint64_t> tags_;  // frame + 1 held by the slot, 0 = empty
    std::vector<std::size_t> used_;    // bytes of the slot's state
};

}  // namespace lockroll::rollback
