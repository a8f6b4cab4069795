// The speculative margin per pair (docs/physics.md, "Speculative margin per pair"): how far each
// dynamic body's surface can move within this step, from its velocities, so that a pair gets
// contact points only when its gap can close within the step. Part of RigidSolver (sim/rigid_solver.h).
#include <cstdint>
#include <vector>

#include "sim/fixed.h"
#include "sim/rigid_solver.h"

namespace lockroll::sim {

void RigidSolver::closing_reach(const std::vector<Vec3>& vel, const std::vector<Vec3>& angvel, std::size_t begin,
                                std::size_t end) {
    // A point further apart than the surfaces can close within the step (plus the base, for
    // what the iterations add: a body pushed by its neighbours) constrains nothing this step;
    // with every pair within the scene's margin getting points, the piles solved ~1.5x Bullet's
    // points (docs/performance.md, "Fewer contact points"). |v_a|_1 + |v_b|_1 bounds the
    // pairs' relative normal speed from above, and |w|_1 r the speed a turn gives a surface
    // point at distance r from the centre; exact integer arithmetic, per body, so a pair costs
    // two additions (pair_margin()).
    for (std::size_t i = begin; i < end; ++i) {
        const BodyId id = dynamic_[i];
        closing_[id] = closing_bound(vel[id], angvel[id], turn_reach_[id], cap_speed_, margin_, dt_);
    }
}

Fixed RigidSolver::closing_bound(const Vec3& v, const Vec3& w, Fixed reach, Fixed cap_speed, Fixed margin, Fixed dt) {
    const auto magnitude = [](Fixed f) {
        return f.raw < 0 ? std::uint64_t{0} - static_cast<std::uint64_t>(f.raw) : static_cast<std::uint64_t>(f.raw);
    };
    // Each magnitude < 2^64, so three sum below 2^66, and three products with reach < 2^63
    // below 2^128: nothing wraps.
    u128 speed = u128(magnitude(v.x)) + magnitude(v.y) + magnitude(v.z);
    if (reach.raw != 0) {
        const std::uint64_t r = magnitude(reach);
        const u128 turn = mul_wide_unsigned(magnitude(w.x), r) + mul_wide_unsigned(magnitude(w.y), r) +
                          mul_wide_unsigned(magnitude(w.z), r);
        // To Fixed as a Fixed product rounds: to nearest, ties to even.
        u128 q = turn >> Fixed::kFracBits;
        const std::uint64_t rem = static_cast<std::uint64_t>(turn) & ((std::uint64_t{1} << Fixed::kFracBits) - 1);
        const std::uint64_t half = std::uint64_t{1} << (Fixed::kFracBits - 1);
        if (rem > half || (rem == half && (static_cast<std::uint64_t>(q) & 1) != 0)) q = q + 1;
        speed = speed + q;
    }
    // speed dt > margin, without forming the product for absurd speeds.
    if (speed > u128(static_cast<std::uint64_t>(cap_speed.raw))) return margin;
    return Fixed::from_raw(static_cast<std::int64_t>(static_cast<std::uint64_t>(speed))) * dt;
}

}  // namespace lockroll::sim
