// One player's input stream: confirmed inputs by frame, and the input each frame was last
// simulated with (confirmed or predicted), so a late confirmed input can be compared with what
// was actually used.
//
// Contract
//  - Frames [0, confirmed_count()) are confirmed: a contiguous prefix. Inputs are only accepted in
//    order (frame == confirmed_count()); anything after a gap is dropped, because the sender
//    resends every unacknowledged input and the next packet fills the gap. That keeps "confirmed"
//    a single number, which is what acks, stalls and checksums are built on.
//  - A confirmed input never changes. A second copy with different bytes is a Conflict (the
//    remote rewrote its past: a protocol violation the session counts as a bad packet).
//  - Each confirmed input carries an "absent" flag: the slot had no player for that frame (not
//    joined yet, or disconnected), and the input is the neutral one written by the slot's
//    owner. The flag is part of the input: a copy with another flag is a Conflict too.
//  - Storage is a ring of `capacity` frames allocated once. The owner says how far back it will
//    ever read again (discard_before); a frame at or beyond floor() + capacity cannot be stored
//    yet (TooFarAhead, dropped, resent later) rather than overwrite something still needed.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace lockroll::rollback {

class InputQueue {
public:
    enum class Add { Stored, Duplicate, Conflict, Gap, TooFarAhead, TooOld };

    // capacity: frames held at once; must be a power of two. input_size: bytes per input (>= 1).
    InputQueue(std::size_t input_size, std::uint32_t capacity);

    std::size_t input_size() const { return input_size_; }
    std::uint32_t capacity() const { return capacity_; }
    std::uint32_t confirmed_count() const { return confirmed_count_; }
    std::uint32_t floor() const { return floor_; }

    // Frames before `frame` will never be read again. Never moves the floor back.
    void discard_before(std::uint32_t frame);

    Add add_confirmed(std::uint32_t frame, std::span<const std::uint8_t> input, bool absent = false);
    // The one exception to "a confirmed input never changes": a running slot's input that a
    // relay filled in is replaced by its owner's own copy (rollback/input_authority.h), before
    // any confirmed frame rests on it. floor() <= frame < confirmed_count() and the right size,
    // else false and nothing changes. The absent flag is cleared (an owner's input is its own).
    bool replace_confirmed(std::uint32_t frame, std::span<const std::uint8_t> input);

    // floor() <= frame < confirmed_count().
    std::span<const std::uint8_t> confirmed(std::uint32_t frame) const;
    bool confirmed_absent(std::uint32_t frame) const { return absent_[frame & (capacity_ - 1)] != 0; }
    // The inputs an input message resends (both sessions): up to `max` confirmed inputs from
    // max(from, floor()) on, copied into out (resized to count * input_size()).
    struct Run {
        std::uint32_t first = 0;
        std::uint32_t count = 0;
    };
    Run copy_confirmed(std::uint32_t from, std::uint32_t max, std::vector<std::uint8_t>& out) const;
    // Whether the newest confirmed input was flagged absent.
    bool last_absent() const { return last_absent_; }

    // Starts the stream over at `frame` (a snapshot of that frame was loaded): nothing is
    // confirmed before it, nothing after it is known, and nothing was simulated yet.
    void restart_at(std::uint32_t frame);
    // The newest confirmed input (kept even after its slot is discarded); empty before the first.
    std::span<const std::uint8_t> last_confirmed() const;

    // Records what the latest simulation of `frame` used; floor() <= frame < floor() + capacity().
    void set_used(std::uint32_t frame, std::span<const std::uint8_t> input, bool absent = false);
    // What the latest simulation of `frame` used, if it was simulated and is still held.
    std::optional<std::span<const std::uint8_t>> used(std::uint32_t frame) const;
    // Whether that simulation treated the slot as absent (meaningful when used() has a value).
    bool used_absent(std::uint32_t frame) const { return used_absent_[frame & (capacity_ - 1)] != 0; }

private:
    std::size_t slot(std::uint32_t frame) const { return (frame & (capacity_ - 1)) * input_size_; }

    std::size_t input_size_;
    std::uint32_t capacity_;
    std::uint32_t confirmed_count_ = 0;
    std::uint32_t floor_ = 0;
    std::vector<std::uint8_t> confirmed_;
    std::vector<std::uint8_t> used_;
    std::vector<std::uint32_t> used_tag_;  // frame + 1 whose used input the slot holds, 0 = none
    std::vector<std::uint8_t> absent_;       // per slot: the confirmed input is flagged absent
    std::vector<std::uint8_t> used_absent_;  // per slot: the simulation treated it as absent
    std::vector<std::uint8_t> last_;
    bool last_absent_ = false;
};

}  // namespace lockroll::rollback
