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
        if (b.player >= 0) player_body_[static_cast<std::size_t>(b.player)] = id;
    }
    controller_ = ControllerFactors::from(scene.controller, dt_);
    broadphase_.configure(scene.broadphase, dynamic_, static_, pos_, extent_, scene.contact_margin);
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

void World::prepare_pairs() {
    solver_pairs_.clear();
    for (const BodyPair& pair : pairs_) {
        BodyId a = pair.a, b = pair.b;
        // Canonical roles: a round shape before a box (each routine sees (round, box)); within
        // the same class, a static body second. Only a static round body against a dynamic box
        // leaves the static body first, which the solver mirrors.
        const bool a_round = shape_[a] != Shape::Box, b_round = shape_[b] != Shape::Box;
        if (a_round != b_round ? !a_round : inv_mass_[a].raw == 0) std::swap(a, b);
        SolverPair p;
        p.a = a;
        p.b = b;
        p.kind = shape_[a] == Shape::Box ? PairKind::BoxBox
                 : shape_[b] == Shape::Box ? PairKind::RoundBox
                                           : PairKind::RoundRound;
        const Fixed ea = restitution_[a], eb = restitution_[b];
        const Fixed e = (ea.raw >= 0 || eb.raw >= 0)
                            ? max(ea, eb)  // explicit materials combine by max
                            : scene_.restitution[static_cast<int>(shape_[a])][static_cast<int>(shape_[b])];
        p.one_plus_e = Fixed::one() + e;
        p.b_static = inv_mass_[b].raw == 0;
        p.inv_sum_recip = p.b_static || inv_mass_[a].raw == 0 ? Fixed::zero() : reciprocal(inv_mass_[a] + inv_mass_[b]);
        solver_pairs_.push_back(p);
    }
}

void World::solve_contacts() {
    prepare_pairs();
    for (int iteration = 0; iteration < scene_.iterations; ++iteration) {
        for (const SolverPair& p : solver_pairs_) {
            const BodyId a = p.a, b = p.b;
            Contact c;
            bool touching;
            switch (p.kind) {
                case PairKind::RoundRound:
                    touching = collide(RoundCollider{pos_[a], core_half_[a], radius_[a]},
                                       RoundCollider{pos_[b], core_half_[b], radius_[b]}, c);
                    break;
                case PairKind::RoundBox:
                    touching = collide(RoundCollider{pos_[a], core_half_[a], radius_[a]},
                                       BoxCollider{pos_[b], half_extents_[b]}, c);
                    break;
                default:
                    touching = collide(BoxCollider{pos_[a], half_extents_[a]}, BoxCollider{pos_[b], half_extents_[b]}, c);
                    break;
            }
            if (!touching) continue;

            if (p.b_static) {
                // All of the correction and impulse goes to a: J/m_a = -(1+e) v_n exactly.
                pos_[a] -= c.normal * c.depth;
                const Fixed vn = -dot(vel_[a], c.normal);
                if (vn.raw < 0) vel_[a] += c.normal * (p.one_plus_e * vn);
                continue;
            }
            const Fixed ia = inv_mass_[a], ib = inv_mass_[b];
            if (ia.raw == 0) {
                // Static round body against a dynamic box: mirror of the case above.
                pos_[b] += c.normal * c.depth;
                const Fixed vn = dot(vel_[b], c.normal);
                if (vn.raw < 0) vel_[b] -= c.normal * (p.one_plus_e * vn);
                continue;
            }
            // Positional correction: remove the whole overlap, split by inverse mass.
            const Vec3 push = c.normal * (c.depth * p.inv_sum_recip);
            pos_[a] -= push * ia;
            pos_[b] += push * ib;
            // Impulse J = -(1+e)(v_rel . n) / (1/m_a + 1/m_b), only while approaching.
            const Fixed vn = dot(vel_[b] - vel_[a], c.normal);
            if (vn.raw >= 0) continue;
            const Vec3 impulse = c.normal * (-(p.one_plus_e * vn) * p.inv_sum_recip);
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
