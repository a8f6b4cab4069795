// The real-time layer's clock: microseconds from a monotonic clock. This is the ONLY place in
// lockroll that reads a clock to make decisions; everything below net/ (rollback/, transport/)
// takes time as an argument, so the same code runs in virtual time in tests and in `lockroll run`.
//
// Contract: monotonic (never goes back, unaffected by wall-clock changes), microsecond units,
// arbitrary epoch (only differences mean anything).
#pragma once

#include <chrono>
#include <cstdint>

namespace lockroll::net {

inline std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
}

}  // namespace lockroll::net
