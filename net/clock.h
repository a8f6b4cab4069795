// The one clock lockroll reads: a monotonic microsecond count for the real-time layer.
//
// Everything below net/ (rollback/, transport/) takes time as an argument and never reads a
// clock; this is where real time enters. steady_clock never jumps backwards (NTP adjustments
// and manual clock changes do not affect it), which is what tick scheduling and RTT need.
#pragma once

#include <chrono>
#include <cstdint>

namespace lockroll::net {

// Microseconds since an unspecified fixed point (the machine's boot, on Linux); only
// differences mean anything.
inline std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
}

}  // namespace lockroll::net
