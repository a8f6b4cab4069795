// SplitMix64: the integer generator behind scene spawners. Integer-only and specified to the
// bit, so a seed gives the same scene on every platform.
#pragma once

#include <cstdint>

#include "sim/fixed.h"

namespace lockroll::sim {

class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : state_(seed) {}

    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }

    // Uniform raw value in [0, bound) without modulo bias (Lemire's multiply-shift, with
    // rejection). bound must be > 0.
    std::uint64_t below(std::uint64_t bound) {
        for (;;) {
            const u128 m = mul_wide_unsigned(next(), bound);
            const auto low = static_cast<std::uint64_t>(m);
            if (low >= bound || low >= (0 - bound) % bound) return static_cast<std::uint64_t>(m >> 64);
        }
    }

private:
    std::uint64_t state_;
};

}  // namespace lockroll::sim
