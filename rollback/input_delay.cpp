#include "rollback/input_delay.h"

#include <algorithm>

namespace lockroll::rollback {

int lockstep_input_delay(std::uint64_t reach_us, int tick_rate) {
    const auto rate = static_cast<std::uint64_t>(std::max(tick_rate, 1));
    // Frames past kMaxInputDelay are all the same answer; capping reach first keeps the product
    // far from overflow for any reach (an hour at 10 kHz is 3.6e13).
    const std::uint64_t cap_us = static_cast<std::uint64_t>(kMaxInputDelay) * 1000000 / rate + 1;
    const std::uint64_t r = std::min(reach_us, cap_us);
    const auto frames = static_cast<int>((r * rate + 999999) / 1000000);
    return std::min(frames + 1, kMaxInputDelay);
}

int rollback_input_delay(std::uint64_t reach_us, int tick_rate) {
    return (lockstep_input_delay(reach_us, tick_rate) + 1) / 2;
}

int auto_input_delay(int prediction_window, std::uint64_t reach_us, int tick_rate) {
    return prediction_window == 0 ? lockstep_input_delay(reach_us, tick_rate) : rollback_input_delay(reach_us, tick_rate);
}

int adaptive_input_delay(int prediction_window, std::uint64_t reach_us, int tick_rate) {
    const int lockstep = lockstep_input_delay(reach_us, tick_rate);
    if (prediction_window == 0) return lockstep;
    return std::max(rollback_input_delay(reach_us, tick_rate), lockstep - prediction_window + 1);
}

}  // namespace lockroll::rollback
