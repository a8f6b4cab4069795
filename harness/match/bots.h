// Input bots: seeded, deterministic stand-ins for players, producing one PlayerInput per frame.
//
// A bot's input is a pure function of (config, slot, frame, world state): no hidden state, no
// clock, integer arithmetic only. Every client that re-runs a frame (a rollback, a replay, a
// second process) computes the same input, so bots never cause a desync by themselves, and a
// run is reproducible from its seed alone.
//
//  - random: holds a stick direction (one of 16 compass points, full tilt) and switches to a new
//    random one at random frames, on average changes_per_second times per second; one direction
//    in eight is "stand still", and one switch in eight begins with a short hop (up = 127 for
//    the first 6 frames). The player's path is a random walk.
//  - chase: steers its player body toward the nearest ball (a dynamic sphere that is not a
//    player body; ties go to the lower body id), full tilt on the dominant horizontal axis and
//    proportionally on the other; presses up while the ball is more than 1 m above. With no
//    ball in the world it behaves like random.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include <lockroll/sim/world.h>

namespace lockroll::harness {

enum class BotKind : std::uint8_t { Random = 0, Chase = 1 };

// "random" | "chase"; nullopt for anything else (the CLI reports it).
std::optional<BotKind> parse_bot_kind(std::string_view name);
const char* bot_kind_name(BotKind kind);

struct BotConfig {
    BotKind kind = BotKind::Random;
    std::uint64_t seed = 1;
    int tick_rate = 60;               // frames per second the change rate is measured against
    double changes_per_second = 4.0;  // random walk; quantised once to a per-frame threshold
};

class Bot {
public:
    // Throws std::invalid_argument for tick_rate <= 0, a negative or non-finite change rate, or
    // a rate above one change per frame.
    Bot(const BotConfig& config, int slot);

    // The input of this bot's player slot for `frame`, given the world the client has when it
    // produces that input. A slot the world has no player for gets a neutral input.
    sim::PlayerInput input(std::uint32_t frame, const sim::World& world) const;

    int slot() const { return slot_; }
    const BotConfig& config() const { return config_; }

    // The random-walk part alone (depends only on seed, slot and frame).
    sim::PlayerInput random_walk(std::uint32_t frame) const;

private:
    bool changes_at(std::uint32_t frame) const;
    std::uint64_t draw(std::uint32_t frame, std::uint64_t purpose) const;

    BotConfig config_;
    int slot_;
    std::uint64_t change_threshold_;  // per-frame change chance, scaled to 2^32
};

// The ball nearest to player slot `slot`'s body (squared distance at 2^-24 m resolution,
// integer only; ties to the lower id); nullopt when the world has no such player or no ball.
std::optional<sim::BodyId> nearest_ball(const sim::World& world, int slot);

// Input steering from `from` toward `to` as the chase bot does it (exposed for tests).
sim::PlayerInput steer_toward(const sim::Vec3& from, const sim::Vec3& to);

}  // namespace lockroll::harness
