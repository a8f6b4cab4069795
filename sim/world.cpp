#include "sim/world.h"

#include <stdexcept>

#include "sim/contact.h"

namespace lockroll::sim {

World::World(const SceneDesc& scene) : scene_(scene) {
    if (const std::string err = validate(scene); !err.empty()) throw std::invalid_argument(err);
    dt_ = Fixed::ratio(1, scene.tick_rate);
    const std::size_t n = scene.bodies.size();
    pos_.resize(n);
    vel_.resize(n);
    shape_.resize(n);
    extent_.resize(n);
    radius_.resize(n);
    core_half_.resize(n);
    half_extents_.resize(n);
    inv_mass_.resize(n);
    gravity_dv_.resize(n);
    restitution_.resize(n);
    player_body_.resize(static_cast<std::size_t>(sim::player_count(scene)));
    Fixed max_extent;
    for (std::size_t i = 0; i < n; ++i) {
        const BodyDesc& b = scene.bodies[i];
        const auto id = static_cast<BodyId>(i);
        pos_[i] = b.position;
        shape_[i] = b.shape;
        switch (b.shape) {
            case Shape::Sphere:
                radius_[i] = b.radius;
                extent_[i] = {b.radius, b.radius, b.radius};
                break;
            case Shape::Capsule:
                radius_[i] = b.radius;
                core_half_[i] = b.half_height;
                extent_[i] = {b.radius, b.radius + b.half_height, b.radius};
                break;
            case Shape::Box:
                half_extents_[i] = b.half_extents;
                extent_[i] = b.half_extents;
                break;
        }
        restitution_[i] = b.restitution ? *b.restitution : Fixed::from_raw(-1);
        if (b.mass.raw == 0) {
            static_.push_back(id);
            continue;
        }
        dynamic_.push_back(id);
        vel_[i] = b.velocity;
        inv_mass_[i] = reciprocal(b.mass);
        gravity_dv_[i] = scene.gravity * (b.gravity_scale * dt_);
        max_extent = max(max_extent, max(max(extent_[i].x, extent_[i].y), extent_[i].z));
        if (b.player >= 0) player_body_[static_cast<std::size_t>(b.player)] = id;
    }
    controller_ = ControllerFactors::from(scene.controller, dt_);
    broadphase_.configure(scene.broadphase, dynamic_, static_, max_extent, scene.contact_margin);
    // Whatever scene construction saturated is part of the initial state.
    overflow_count_ = 0;
}

void World::step(std::span<const PlayerInput> inputs) {
    const std::uint64_t overflow_before = overflow_events();
    for (BodyId id : dynamic_) vel_[id] += gravity_dv_[id];
    if (!player_body_.empty()) apply_controller(inputs);
    for (BodyId id : dynamic_) pos_[id] += vel_[id] * dt_;
    broadphase_.find_pairs(pos_, extent_, pairs_);
    solve_contacts();
    ++frame_;
    overflow_count_ += overflow_events() - overflow_before;
}

void World::apply_controller(std::span<const PlayerInput> inputs) {
    for (std::size_t slot = 0; slot < player_body_.size(); ++slot) {
        const PlayerInput in = slot < inputs.size() ? inputs[slot] : PlayerInput{};
        apply_input(controller_, in, vel_[player_body_[slot]]);
    }
}

void World::solve_contacts() {
    const auto table_e = [&](BodyId a, BodyId b) {
        const Fixed ea = restitution_[a], eb = restitution_[b];
        if (ea.raw >= 0 || eb.raw >= 0) return max(ea, eb);  // explicit materials combine by max
        return scene_.restitution[static_cast<int>(shape_[a])][static_cast<int>(shape_[b])];
    };
    for (int iteration = 0; iteration < scene_.iterations; ++iteration) {
        for (const BodyPair& pair : pairs_) {
            BodyId a = pair.a, b = pair.b;
            // Order by shape so each routine sees (round, box) and never (box, round).
            if (shape_[a] == Shape::Box && shape_[b] != Shape::Box) std::swap(a, b);
            Contact c;
            bool touching;
            if (shape_[a] != Shape::Box && shape_[b] != Shape::Box)
                touching = collide(RoundCollider{pos_[a], core_half_[a], radius_[a]},
                                   RoundCollider{pos_[b], core_half_[b], radius_[b]}, c);
            else if (shape_[a] != Shape::Box)
                touching = collide(RoundCollider{pos_[a], core_half_[a], radius_[a]},
                                   BoxCollider{pos_[b], half_extents_[b]}, c);
            else
                touching = collide(BoxCollider{pos_[a], half_extents_[a]}, BoxCollider{pos_[b], half_extents_[b]}, c);
            if (!touching) continue;

            const Fixed ia = inv_mass_[a], ib = inv_mass_[b];
            const Fixed inv_sum = ia + ib;
            if (inv_sum.raw == 0) continue;
            // Positional correction: remove the whole overlap, split by inverse mass.
            const Vec3 push = c.normal * (c.depth / inv_sum);
            pos_[a] -= push * ia;
            pos_[b] += push * ib;
            // Impulse J = -(1+e)(v_rel . n) / (1/m_a + 1/m_b), only while approaching.
            const Fixed vn = dot(vel_[b] - vel_[a], c.normal);
            if (vn.raw >= 0) continue;
            const Fixed j = -((Fixed::one() + table_e(a, b)) * vn) / inv_sum;
            const Vec3 impulse = c.normal * j;
            vel_[a] -= impulse * ia;
            vel_[b] += impulse * ib;
        }
    }
}

void World::flip_bit(BodyId id, int field, int bit) {
    Vec3& v = field < 3 ? pos_[id] : vel_[id];
    Fixed& f = (field % 3 == 0) ? v.x : (field % 3 == 1) ? v.y : v.z;
    f.raw = static_cast<std::int64_t>(static_cast<std::uint64_t>(f.raw) ^ (std::uint64_t{1} << (bit & 63)));
}

}  // namespace lockroll::sim
