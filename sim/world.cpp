#include "sim/world.h"

#include <stdexcept>

namespace lockroll::sim {

namespace {
const SceneDesc& validated(const SceneDesc& scene) {
    if (const std::string err = validate(scene); !err.empty()) throw std::invalid_argument(err);
    return scene;
}
}  // namespace

World::World(const SceneDesc& scene) : scene_(validated(scene)), kernel_(scene_) {
    kernel_.initial_state(scene_, pos_, vel_);
    player_body_.resize(static_cast<std::size_t>(sim::player_count(scene_)));
    for (std::size_t i = 0; i < scene_.bodies.size(); ++i)
        if (scene_.bodies[i].player >= 0)
            player_body_[static_cast<std::size_t>(scene_.bodies[i].player)] = static_cast<BodyId>(i);
    controller_ = ControllerFactors::from(scene_.controller, kernel_.dt());
    rigid_.configure(scene_, kernel_);
    if (rigid_.enabled()) rigid_.initial_state(scene_, orient_, angvel_);
    impulses_.reserve(rigid_.impulse_capacity());  // steps and loads never allocate for it
    broadphase_.configure(scene_.broadphase, kernel_.dynamic_ids(), kernel_.static_ids(), pos_,
                          rigid_.enabled() ? rigid_.extent() : kernel_.extent(), scene_.contact_margin);
    // Whatever scene construction saturated is part of the initial state.
    overflow_count_ = 0;
}

void World::step(std::span<const PlayerInput> inputs) {
    const std::uint64_t overflow_before = overflow_events();
    const auto control = [this, inputs](std::vector<Vec3>&) {
        if (!player_body_.empty()) apply_controller(inputs);
    };
    if (rigid_.enabled())
        rigid_.step(
            pos_, vel_, orient_, angvel_, impulses_,
            [this](const std::vector<Vec3>& pos, std::vector<BodyPair>& out) {
                broadphase_.find_pairs(pos, rigid_.extent(), out);
            },
            control);
    else
        kernel_.step(
            pos_, vel_,
            [this](const std::vector<Vec3>& pos, std::vector<BodyPair>& out) {
                broadphase_.find_pairs(pos, kernel_.extent(), out);
            },
            control);
    ++frame_;
    overflow_count_ += overflow_events() - overflow_before;
}

void World::apply_controller(std::span<const PlayerInput> inputs) {
    for (std::size_t slot = 0; slot < player_body_.size(); ++slot) {
        const PlayerInput in = slot < inputs.size() ? inputs[slot] : PlayerInput{};
        apply_input(controller_, in, vel_[player_body_[slot]]);
    }
}

void World::flip_bit(BodyId id, int field, int bit) {
    if (field >= 6 && field < 10) {
        Quat& q = orient_[id];
        Fixed& f = field == 6 ? q.w : field == 7 ? q.x : field == 8 ? q.y : q.z;
        // Bit b of the stored int32 (raw / 4): the flipped value stays on the 2^-30 grid.
        const auto stored = static_cast<std::uint32_t>(static_cast<std::int32_t>(f.raw / 4)) ^ (std::uint32_t{1} << (bit & 31));
        f.raw = static_cast<std::int64_t>(static_cast<std::int32_t>(stored)) * 4;
        return;
    }
    Vec3& v = field < 3 ? pos_[id] : field < 6 ? vel_[id] : angvel_[id];
    const int k = field < 6 ? field % 3 : field - 10;
    Fixed& f = k == 0 ? v.x : k == 1 ? v.y : v.z;
    f.raw = static_cast<std::int64_t>(static_cast<std::uint64_t>(f.raw) ^ (std::uint64_t{1} << (bit & 63)));
}

}  // namespace lockroll::sim
