// The simulated network's private generator: SplitMix64 addressed by position, so any draw can
// be computed directly as a pure function of (seed, position) without stepping through the
// ones before it. The network gives every directed link its own stream and every packet a
// fixed block of positions in it, so what happens to packet n on a link depends only on the
// seed, the link and n -- not on traffic elsewhere, nor on how many draws earlier packets used.
//
// Integer-only and specified to the bit; ranges are mapped with a 64x64->128 multiply-shift
// (bias below bound / 2^64, i.e. under 2^-40 for any bound a network uses), never with the
// standard library's distributions, whose output differs between implementations.
#pragma once

#include <cmath>
#include <cstdint>

namespace lockroll::transport {

class CounterRng {
public:
    static constexpr std::uint64_t kGamma = 0x9E3779B97F4A7C15ull;

    static constexpr std::uint64_t mix(std::uint64_t z) {
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }

    // A stream key from a seed and two 32-bit labels (e.g. the ends of a link).
    static constexpr CounterRng derive(std::uint64_t seed, std::uint32_t a, std::uint32_t b) {
        const std::uint64_t k = mix(mix(seed + kGamma) ^ ((std::uint64_t{a} << 32) | b));
        return CounterRng(k);
    }

    constexpr explicit CounterRng(std::uint64_t key) : key_(key) {}

    // The value at `position`: identical to the (position+1)-th output of SplitMix64(key).
    constexpr std::uint64_t at(std::uint64_t position) const { return mix(key_ + (position + 1) * kGamma); }

    // Uniform in [0, bound); bound 0 gives 0.
    static constexpr std::uint64_t below(std::uint64_t raw, std::uint64_t bound) {
        return static_cast<std::uint64_t>((static_cast<unsigned __int128>(raw) * bound) >> 64);
    }

private:
    std::uint64_t key_;
};

// A probability quantised to a 32-bit threshold: an event happens when the top 32 bits of a
// raw draw are below it. 0 never happens, 2^32 (probability 1) always does. The conversion
// from double is exact scaling plus one rounding, the same on every IEEE-754 machine.
struct Chance {
    std::uint64_t threshold = 0;

    // p outside [0, 1] (or NaN) clamps; callers validate first (see validate(LinkConditions)).
    static Chance from_probability(double p) {
        if (!(p > 0.0)) return {0};
        if (p >= 1.0) return {std::uint64_t{1} << 32};
        return {static_cast<std::uint64_t>(std::llround(p * 4294967296.0))};
    }
    bool hit(std::uint64_t raw) const { return (raw >> 32) < threshold; }
};

}  // namespace lockroll::transport
