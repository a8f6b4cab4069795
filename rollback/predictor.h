// Guessing a remote player's input before it arrives.
//
// Why pluggable: "repeat the last confirmed input" is the classic choice and right for sticks
// and held buttons, but a game may know better (decay toward neutral, replay a pattern). A bad
// guess only costs a rollback, never correctness: confirmed frames use confirmed inputs only.
// A predictor may keep state, but the session asks for the same (player, frame) again after a
// rollback and compares whatever it answered last time.
#pragma once

#include <cstdint>
#include <span>

#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

class Predictor {
public:
    virtual ~Predictor() = default;
    // Writes a guess for `player`'s input of `frame` into `out` (input_size bytes).
    // last_confirmed: that player's newest confirmed input (for frame last_frame), or empty
    // when none has arrived yet.
    virtual void predict(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> last_confirmed,
                         std::uint32_t last_frame, std::span<std::uint8_t> out) = 0;
};

// Repeats the last confirmed input; all zero bytes before the first one.
class RepeatLastPredictor final : public Predictor {
public:
    void predict(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> last_confirmed,
                 std::uint32_t last_frame, std::span<std::uint8_t> out) override;
};

}  // namespace lockroll::rollback
