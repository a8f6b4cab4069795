// The motion of the rigid bodies between contact solves: damping, the world-frame inverse inertia
// each step's rows use, and the integration of positions and orientations (a box's free
// rotation conserves its angular momentum; an isotropic body's exponential map is exact).
// Part of RigidSolver (sim/rigid_solver.h).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sim/fixed.h"
#include "sim/rigid_solver.h"

namespace lockroll::sim {

namespace {
// The componentwise product (a diagonal matrix times a vector).
Vec3 hadamard(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
}  // namespace

void RigidSolver::damp(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, std::size_t begin, std::size_t end) const {
    for (std::size_t i = begin; i < end; ++i) {
        const BodyId id = dynamic_[i];
        if (lin_damp_[id] != Fixed::one()) vel[id] = vel[id] * lin_damp_[id];
        if (ang_damp_[id] != Fixed::one()) angvel[id] = angvel[id] * ang_damp_[id];
    }
}

void RigidSolver::update_inertia(const std::vector<Quat>& orient, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
        const BodyId id = dynamic_[i];
        // A sphere's collider never reads its rotation (nor does an isotropic body's inertia or
        // integration), so it is not built.
        // A box integrate() turned has its new rotation in rot_memo_ (unless something turned
        // it since: then the quaternions differ).
        if (shape_[id] == Shape::Box || core_half_[id].raw != 0) {
            const RotationMemo& memo = rot_memo_[rot_memo_at_[id]];
            rot_[id] = memo.q == orient[id] ? memo.m : rotation(orient[id]);
        }
        if (isotropic_[id]) {
            const Fixed s = inv_inertia_[id].x, z = Fixed::zero();
            inv_i_world_[id] = {{{s, z, z}, {z, s, z}, {z, z, s}}};
        } else {
            inv_i_world_[id] = rotate_diagonal(rot_[id], inv_inertia_[id]);
        }
    }
}

Vec3 RigidSolver::omega_from(BodyId id, const Quat& q, const Vec3& l) const {
    return rotate_scaled(q, rotation(q), inv_inertia_[id], l);
}

void RigidSolver::integrate(std::vector<Vec3>& pos, const std::vector<Vec3>& vel, std::vector<Quat>& orient,
                            std::vector<Vec3>& angvel, std::size_t begin, std::size_t end) const {
    const Fixed half_dt = Fixed::from_raw(dt_.raw / 2);
    // Each body's real motion, then its pseudo motion, as one sweep gives them.
    for (std::size_t i = begin; i < end; ++i) {
        const BodyId id = dynamic_[i];
        pos[id] += vel[id] * dt_;
        const Vec3 w = angvel[id];
        if (w == Vec3{}) continue;
        if (isotropic_[id]) {  // w is constant between impulses: the exponential map is exact
            orient[id] = integrated(orient[id], w, dt_);
            continue;
        }
        // Angular momentum, conserved by the free motion: L = R I R^T w.
        const Mat3& r = rot_[id];
        const Vec3 l = r * hadamard(inertia_[id], transpose_times(r, w));
        const Quat half = integrated(orient[id], w, half_dt);
        const Vec3 w_half = omega_from(id, half, l);
        orient[id] = integrated(orient[id], w_half, dt_);
        RotationMemo& memo = rot_memo_[rot_memo_at_[id]];
        memo.q = orient[id];
        memo.m = rotation(memo.q);
        angvel[id] = rotate_scaled(memo.q, memo.m, inv_inertia_[id], l);
    }
    if (!split_) return;
    // Split impulses: the pseudo motion, after the real one, then dropped.
    for (std::size_t i = begin; i < end; ++i) {
        const BodyId id = dynamic_[i];
        const std::uint32_t k = slot_[id];
        if (k == kNoSlot) continue;  // no contact: no pseudo motion
        if (pseudo_[k].v != Vec3{}) pos[id] += pseudo_[k].v * dt_;
        if (pseudo_[k].w != Vec3{}) orient[id] = integrated(orient[id], pseudo_[k].w, dt_);
    }
}

}  // namespace lockroll::sim
