#include "rollback/simulation.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <cstdio>

namespace lockroll::rollback {

std::uint64_t Simulation::checksum(std::span<const std::uint8_t> state) const {
    return XXH3_64bits(state.data(), state.size());
}

std::uint64_t Simulation::body_hash(std::span<const std::uint8_t>, std::uint32_t) const { return 0; }

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
