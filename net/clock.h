// The real-time layer's clock: microseconds from a monotonic clock. This is the ONLY place in
// lockroll that reads a clock to make decisions; everything below net/ (rollback/, transport/)
// takes time as an argument, so the same code runs in virtual time in tests and in `lockroll run`.
//
// Contract: monotonic (never goes back, unaffected by wall-clock changes), microsecond units,
// arbitrary epoch (only differences mean anything).
//
// Clock is the same clock as one process sees it: running at (1 + skew_ppm / 10^6) times the
// monotonic rate from the moment it was made, as on a machine whose oscillator runs fast or slow.
// skew 0 (the default) is now_us() itself. It exists for the clock-skew fault tests (`lockroll
// peer --clock-skew-ppm`, docs/reliability.md): everything a PeerRunner times goes through it.
// Still monotonic (the rate stays >= 0.5), microseconds, exact integer arithmetic.
//
// thread_cpu_ns() is the calling thread's CPU time, for telemetry only (the sessions' cpu_clock:
// CPU per tick, rollback cost); it decides nothing.
#pragma once

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace lockroll::net {

inline std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
}

std::uint64_t thread_cpu_ns();  // net/clock.cpp (POSIX CLOCK_THREAD_CPUTIME_ID)

class Clock {
public:
    static constexpr std::int32_t kMaxSkewPpm = 500000;  // +-50 %

    // Throws std::invalid_argument when |skew_ppm| > kMaxSkewPpm.
    explicit Clock(std::int32_t skew_ppm = 0) : epoch_us_(net::now_us()), skew_ppm_(skew_ppm) {
        if (skew_ppm < -kMaxSkewPpm || skew_ppm > kMaxSkewPpm)
            throw std::invalid_argument("clock skew " + std::to_string(skew_ppm) + " ppm is outside +-" +
                                        std::to_string(kMaxSkewPpm));
    }

    std::int32_t skew_ppm() const { return skew_ppm_; }

    // This clock's time: the epoch plus the monotonic time since, scaled.
    std::uint64_t now_us() const { return epoch_us_ + scaled(net::now_us() - epoch_us_); }

    // Monotonic microseconds that pass while this clock advances by `us` (how long to sleep).
    std::uint64_t monotonic_span_us(std::uint64_t us) const {
        if (skew_ppm_ == 0) return us;
        const auto rate = static_cast<std::uint64_t>(1000000 + skew_ppm_);
        return us / rate * 1000000u + us % rate * 1000000u / rate;
    }

    // The monotonic time (net::now_us()) at which this clock read `us`: events written by
    // different processes stay comparable on one machine.
    std::uint64_t to_monotonic_us(std::uint64_t us) const {
        return us <= epoch_us_ ? us : epoch_us_ + monotonic_span_us(us - epoch_us_);
    }

private:
    std::uint64_t scaled(std::uint64_t elapsed) const {
        if (skew_ppm_ == 0) return elapsed;
        // elapsed * (10^6 + skew) / 10^6 without overflow for any run length.
        const std::int64_t whole = static_cast<std::int64_t>(elapsed / 1000000u) * skew_ppm_;
        const std::int64_t part = static_cast<std::int64_t>(elapsed % 1000000u) * skew_ppm_ / 1000000;
        return static_cast<std::uint64_t>(static_cast<std::int64_t>(elapsed) + whole + part);
    }

    std::uint64_t epoch_us_;
    std::int32_t skew_ppm_;
};

}  // namespace lockroll::net
