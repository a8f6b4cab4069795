#include "rollback/world_simulation.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <stdexcept>

#include "sim/snapshot.h"

namespace lockroll::rollback {

std::array<std::uint8_t, kWorldInputSize> encode_input(const sim::PlayerInput& in) {
    return {static_cast<std::uint8_t>(in.forward), static_cast<std::uint8_t>(in.right),
            static_cast<std::uint8_t>(in.up)};
}

sim::PlayerInput decode_input(std::span<const std::uint8_t> b) {
    return {static_cast<std::int8_t>(b[0]), static_cast<std::int8_t>(b[1]), static_cast<std::int8_t>(b[2])};
}

WorldSimulation::WorldSimulation(const sim::SceneDesc& scene, int players)
    : world_(scene), decoded_(static_cast<std::size_t>(std::max(players, 0))) {
    if (players < 1) throw std::invalid_argument("WorldSimulation needs at least one player slot");
}

void WorldSimulation::step(std::span<const std::uint8_t> inputs) {
    for (std::size_t p = 0; p < decoded_.size(); ++p) {
        const std::size_t at = p * kWorldInputSize;
        decoded_[p] = at + kWorldInputSize <= inputs.size() ? decode_input(inputs.subspan(at, kWorldInputSize))
                                                            : sim::PlayerInput{};
    }
    world_.step(decoded_);
}

std::size_t WorldSimulation::state_size() const { return sim::snapshot_capacity(world_); }
std::size_t WorldSimulation::saved_size() const { return sim::snapshot_size(world_); }

void WorldSimulation::save(std::span<std::uint8_t> out) const { sim::save(world_, out); }

std::string WorldSimulation::load(std::span<const std::uint8_t> in) { return sim::load(world_, in); }

// Same value as sim::checksum(world) for the world the bytes were saved from.
std::uint64_t WorldSimulation::checksum(std::span<const std::uint8_t> state) const {
    return XXH3_64bits(state.data(), state.size());
}

int WorldSimulation::field_count() const { return sim::body_field_count(world_); }

std::uint32_t WorldSimulation::body_count() const { return static_cast<std::uint32_t>(world_.dynamic_count()); }

std::uint32_t WorldSimulation::body_id(std::uint32_t index) const { return world_.dynamic_ids()[index]; }

// Same value as sim::body_hash(world, id): XXH3-64 of the body's snapshot bytes (and, with
// warm starting, its carried contact impulses) seeded with its id.
std::uint64_t WorldSimulation::body_hash(std::span<const std::uint8_t> state, std::uint32_t index) const {
    return sim::snapshot_body_hash(world_, state, index);
}

const char* WorldSimulation::field_name(int field) const {
    return field >= 0 && field < field_count() ? sim::kBodyFieldNames[field] : "?";
}

std::int64_t WorldSimulation::field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const {
    return sim::snapshot_field(state, index, field);
}

std::string WorldSimulation::describe_state(std::span<const std::uint8_t> state) const {
    std::string out;
    char buf[160];
    std::uint64_t overflow = 0;
    std::uint32_t frame = 0;
    for (int i = 0; i < 4; ++i) frame |= std::uint32_t{state[8 + i]} << (8 * i);
    for (int i = 0; i < 8; ++i) overflow |= std::uint64_t{state[16 + i]} << (8 * i);
    std::snprintf(buf, sizeof buf, "frame %" PRIu32 " overflow_count %" PRIu64 " bodies %u\n", frame, overflow,
                  body_count());
    out += buf;
    out += "# body";
    for (int f = 0; f < field_count(); ++f) {
        out += ' ';
        out += sim::kBodyFieldNames[f];
    }
    out += "  (Q32.32 raw, then decimal)\n";
    for (std::uint32_t i = 0; i < body_count(); ++i) {
        std::snprintf(buf, sizeof buf, "%u", body_id(i));
        out += buf;
        for (int f = 0; f < field_count(); ++f) {
            const std::int64_t raw = field_value(state, i, f);
            if (f == sim::kRigidFields)  // the sleep word: a count or 4294967295 (asleep), no decimal
                std::snprintf(buf, sizeof buf, " %" PRId64, raw);
            else
                std::snprintf(buf, sizeof buf, " %" PRId64 "(%s)", raw, sim::Fixed::from_raw(raw).to_string().c_str());
            out += buf;
        }
        out += '\n';
    }
    return out;
}

bool WorldSimulation::flip_bit(std::uint32_t body_id, int field, int bit) {
    if (body_id >= world_.body_count() || world_.is_static(body_id)) return false;
    if (field < 0 || field >= field_count() || bit < 0 || bit > 63) return false;
    world_.flip_bit(body_id, field, bit);
    return true;
}

}  // namespace lockroll::rollback
