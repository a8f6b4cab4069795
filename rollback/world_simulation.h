// sim::World as a rollback Simulation: the first (and the harness's) game.
//
// Inputs on the wire and in replays are sim::PlayerInput as 3 bytes per player: forward, right,
// up, each an int8 (two's complement). Bodies are the World's *dynamic* bodies in ascending id
// order (what a snapshot stores); body_id() gives the sim::BodyId a person sees in the scene.
// Fields are sim::kBodyFieldNames: position.x/y/z, velocity.x/y/z as raw Q32.32, and in a rigid
// scene also orientation.w/x/y/z and angular_velocity.x/y/z.
//
// The adapter owns its World so that one object is stepped, saved and read by the harness (for
// positions) without a second copy drifting apart.
#pragma once

#include <array>
#include <vector>

#include <lockroll/rollback/simulation.h>
#include <lockroll/sim/scene.h>
#include <lockroll/sim/world.h>

namespace lockroll::rollback {

inline constexpr std::size_t kWorldInputSize = 3;

std::array<std::uint8_t, kWorldInputSize> encode_input(const sim::PlayerInput& in);
sim::PlayerInput decode_input(std::span<const std::uint8_t> bytes);  // needs 3 bytes

class WorldSimulation final : public Simulation {
public:
    // players: how many input slots step() receives (the session's player count). Slots beyond
    // the scene's player bodies are ignored; scene players beyond `players` get neutral input.
    WorldSimulation(const sim::SceneDesc& scene, int players);

    const sim::World& world() const { return world_; }

    using Simulation::step;
    void step(std::span<const std::uint8_t> inputs) override;
    // Capacity; a rigid scene with warm starting saves fewer bytes (saved_size()).
    std::size_t state_size() const override;
    std::size_t saved_size() const override;
    void save(std::span<std::uint8_t> out) const override;
    std::string load(std::span<const std::uint8_t> in) override;
    std::uint64_t checksum(std::span<const std::uint8_t> state) const override;

    std::uint32_t body_count() const override;
    std::uint32_t body_id(std::uint32_t index) const override;
    std::uint64_t body_hash(std::span<const std::uint8_t> state, std::uint32_t index) const override;
    int field_count() const override;
    const char* field_name(int field) const override;
    std::int64_t field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const override;
    std::string describe_state(std::span<const std::uint8_t> state) const override;
    // Only dynamic bodies (static ones are not in the state, so a flip there would diverge
    // without any checksum noticing); field 0..5, bit 0..63.
    bool flip_bit(std::uint32_t body_id, int field, int bit) override;

private:
    sim::World world_;
    std::vector<sim::PlayerInput> decoded_;
};

}  // namespace lockroll::rollback
