#include "harness/match/bots.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sim/rng.h"

namespace lockroll::harness {

namespace {

// Labels that keep the draws for different decisions of the same frame independent.
enum Purpose : std::uint64_t { kChange = 1, kDirection = 2, kIdle = 3, kHop = 4 };

// Random walk bookkeeping: a change also happens every kForcedChangeFrames frames, so finding
// the current direction scans a bounded number of frames back (and never more than that).
constexpr std::uint32_t kForcedChangeFrames = 1024;
constexpr std::uint32_t kHopFrames = 6;

// 16 compass points at full tilt: round(127 cos(k 22.5 deg)), round(127 sin(k 22.5 deg)).
constexpr std::int8_t kCompass[16][2] = {
    {127, 0},   {117, 49},   {90, 90},   {49, 117},   {0, 127},   {-49, 117},  {-90, 90},  {-117, 49},
    {-127, 0},  {-117, -49}, {-90, -90}, {-49, -117}, {0, -127},  {49, -117},  {90, -90}, {117, -49},
};

std::uint64_t mix(std::uint64_t v) { return sim::SplitMix64(v).next(); }

std::int8_t to_axis(sim::i128 num, sim::i128 den) {
    // round(127 * num / den), half away from zero; |num| <= den so the result is in [-127, 127].
    const sim::i128 scaled = 2 * 127 * num;
    const sim::i128 q = (scaled + (scaled < 0 ? -den : den)) / (2 * den);
    return static_cast<std::int8_t>(q);
}

sim::i128 abs128(sim::i128 v) { return v < 0 ? -v : v; }

}  // namespace

std::optional<BotKind> parse_bot_kind(std::string_view name) {
    if (name == "random") return BotKind::Random;
    if (name == "chase") return BotKind::Chase;
    return std::nullopt;
}

const char* bot_kind_name(BotKind kind) {
    switch (kind) {
        case BotKind::Random: return "random";
        case BotKind::Chase: return "chase";
    }
    return "?";
}

Bot::Bot(const BotConfig& config, int slot) : config_(config), slot_(slot) {
    if (config.tick_rate <= 0)
        throw std::invalid_argument("bot: tick_rate must be positive, got " + std::to_string(config.tick_rate));
    if (!std::isfinite(config.changes_per_second) || config.changes_per_second < 0 ||
        config.changes_per_second > config.tick_rate)
        throw std::invalid_argument("bot: changes_per_second must be in [0, tick_rate], got " +
                                    std::to_string(config.changes_per_second));
    // One IEEE division and one rounding: the same threshold on every machine.
    change_threshold_ = static_cast<std::uint64_t>(
        std::llround(config.changes_per_second / config.tick_rate * 4294967296.0));
}

std::uint64_t Bot::draw(std::uint32_t frame, std::uint64_t purpose) const {
    return mix(mix(mix(mix(config_.seed) ^ static_cast<std::uint64_t>(slot_)) ^ frame) ^ purpose);
}

bool Bot::changes_at(std::uint32_t frame) const {
    return frame % kForcedChangeFrames == 0 || (draw(frame, kChange) >> 32) < change_threshold_;
}

sim::PlayerInput Bot::random_walk(std::uint32_t frame) const {
    std::uint32_t start = frame;
    while (!changes_at(start)) --start;  // stops at the latest multiple of kForcedChangeFrames
    sim::PlayerInput in;
    if ((draw(start, kIdle) >> 61) != 0) {  // 7 in 8 segments move
        const auto k = static_cast<std::size_t>(draw(start, kDirection) >> 60);  // 0..15
        in.right = kCompass[k][0];
        in.forward = kCompass[k][1];
    }
    if ((draw(start, kHop) >> 61) == 0 && frame - start < kHopFrames) in.up = 127;
    return in;
}

std::optional<sim::BodyId> nearest_ball(const sim::World& world, int slot) {
    if (slot < 0 || slot >= world.player_count()) return std::nullopt;
    const sim::BodyId me = world.player_body(slot);
    const sim::Vec3& p = world.position(me);
    std::optional<sim::BodyId> best;
    sim::u128 best_d2 = 0;
    for (const sim::BodyId id : world.dynamic_ids()) {
        if (id == me || world.shape(id) != sim::Shape::Sphere || world.scene().bodies[id].player >= 0) continue;
        const sim::Vec3& q = world.position(id);
        // Differences in units of 2^-24 m: |d| < 2^57, so the sum of squares fits 128 bits.
        const auto d = [](sim::Fixed a, sim::Fixed b) {
            const sim::i128 v = (static_cast<sim::i128>(a.raw) - b.raw) >> 8;
            return static_cast<sim::u128>(v * v);
        };
        const sim::u128 d2 = d(q.x, p.x) + d(q.y, p.y) + d(q.z, p.z);
        if (!best || d2 < best_d2) {
            best = id;
            best_d2 = d2;
        }
    }
    return best;
}

sim::PlayerInput steer_toward(const sim::Vec3& from, const sim::Vec3& to) {
    const sim::i128 dx = static_cast<sim::i128>(to.x.raw) - from.x.raw;
    const sim::i128 dy = static_cast<sim::i128>(to.y.raw) - from.y.raw;
    const sim::i128 dz = static_cast<sim::i128>(to.z.raw) - from.z.raw;
    sim::PlayerInput in;
    const sim::i128 m = std::max(abs128(dx), abs128(dz));
    if (m > 0) {
        in.right = to_axis(dx, m);
        in.forward = to_axis(dz, m);
    }
    if (dy > sim::Fixed::kOne) in.up = 127;
    return in;
}

sim::PlayerInput Bot::input(std::uint32_t frame, const sim::World& world) const {
    if (slot_ < 0 || slot_ >= world.player_count()) return {};
    if (config_.kind == BotKind::Chase) {
        if (const auto ball = nearest_ball(world, slot_))
            return steer_toward(world.position(world.player_body(slot_)), world.position(*ball));
    }
    return random_walk(frame);
}

}  // namespace lockroll::harness
