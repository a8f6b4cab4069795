// One player's input for one frame: three signed axes, each in [-127, 127] (-128 is clamped
// to -127 so the range is symmetric). This is all that crosses the network per player-frame.
#pragma once

#include <cstdint>

namespace lockroll::sim {

struct PlayerInput {
    std::int8_t forward = 0;  // +z
    std::int8_t right = 0;    // +x
    std::int8_t up = 0;       // +y

    friend constexpr bool operator==(const PlayerInput&, const PlayerInput&) = default;
};

}  // namespace lockroll::sim
