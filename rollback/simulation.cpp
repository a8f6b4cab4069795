#include "rollback/simulation.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <array>
#include <cstdio>
#include <vector>

namespace lockroll::rollback {

std::span<std::uint8_t> Simulation::save_to(std::span<std::uint8_t> buffer) const {
    const std::size_t n = saved_size();
    if (n > state_size() || n > buffer.size()) return {};
    const auto out = buffer.first(n);
    save(out);
    return out;
}

std::uint64_t Simulation::checksum(std::span<const std::uint8_t> state) const {
    return XXH3_64bits(state.data(), state.size());
}

// Field by field, little-endian, so the hash is the same on every platform and covers exactly
// what field_value() reports: a body whose hash differs always has a field that differs.
std::uint64_t Simulation::body_hash(std::span<const std::uint8_t> state, std::uint32_t index) const {
    const int fields = field_count();
    if (fields <= 0) return 0;
    const std::size_t bytes = static_cast<std::size_t>(fields) * 8;
    std::array<std::uint8_t, 16 * 8> small;  // enough for every simulation the protocol can narrow
    std::vector<std::uint8_t> large;
    std::uint8_t* out = small.data();
    if (bytes > small.size()) {
        large.resize(bytes);
        out = large.data();
    }
    for (int f = 0; f < fields; ++f) {
        const auto v = static_cast<std::uint64_t>(field_value(state, index, f));
        for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(f) * 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
    }
    return XXH3_64bits_withSeed(out, bytes, body_id(index));
}

const char* Simulation::field_name(int) const { return "?"; }

std::int64_t Simulation::field_value(std::span<const std::uint8_t>, std::uint32_t, int) const { return 0; }

std::string Simulation::describe_state(std::span<const std::uint8_t> state) const {
    std::string out;
    char buf[32];
    for (std::size_t i = 0; i < state.size(); ++i) {
        if (i % 32 == 0) {
            if (i != 0) out += '\n';
            std::snprintf(buf, sizeof buf, "%08zx:", i);
            out += buf;
        }
        std::snprintf(buf, sizeof buf, " %02x", state[i]);
        out += buf;
    }
    out += '\n';
    return out;
}

bool Simulation::flip_bit(std::uint32_t, int, int) { return false; }

}  // namespace lockroll::rollback
