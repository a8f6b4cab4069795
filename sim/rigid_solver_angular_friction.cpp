// Spinning (torsional) friction and rolling resistance of RigidSolver (rigid.spinning_friction,
// rigid.rolling_friction; sim/rigid_solver.h, docs/physics.md "Spinning and rolling friction").
//
// Why: a sphere's contact point lies on its normal through the centre, so neither the normal
// nor the tangent (Coulomb) rows can exert a torque about the normal, and a sphere rolling on
// a plane feels no torque opposing the roll either. A settled ball that spins about the
// contact normal, or rolls, keeps doing so until damping stops it: a pile of balls never
// comes to rest (nor sleeps). Real contacts have a finite patch, which gives both torques;
// like Bullet (btSequentialImpulseConstraintSolver's torsional rows) each contact point gets
// angular rows bounded by a coefficient times its normal impulse.
//
// Model and contract, per contact point with normal impulse pn (this pass's accumulated value):
//  - spin row about n: drives n.(w_b - w_a) to zero, its accumulated angular impulse clamped to
//    [-spin_mu pn, spin_mu pn];
//  - rolling rows about t1, t2: drive t.(w_b - w_a) to zero, their accumulated pair clamped to
//    the disc of radius roll_mu pn (isotropic on the tangent plane, as the Coulomb cone is);
//  - the coefficients are lengths (metres): torque = coefficient x normal force. For a ball of
//    radius r the spin bound equals a uniform contact patch of radius 1.5 spin_mu with
//    Coulomb friction mu = 1 (the patch's torque is (2/3) mu a N); rolling resistance is the
//    classic lever arm (the offset of the normal force ahead of the centre).
//  - angular velocity only (no linear change): the rows move w_a by -I_a^-1 d L and w_b by
//    +I_b^-1 d L; a static body is never moved. Exact fixed point, every product rounded once.
//  - no warm start: the accumulated impulses start from zero each step, so they are scratch,
//    not state (the snapshot layout does not change).
#include "sim/grow.h"
#include "sim/rigid_solver.h"
#include "sim/rigid_solver_passes.h"

namespace lockroll::sim {

void RigidSolver::prepare_angular() { grow(angular_rows_, points_.size()); }

void RigidSolver::solve_with_angular(const std::vector<ContactImpulse>& impulses) {
    prepare_angular();
    if (warm_) warm_start(impulses, AllPoints{});
    for (int i = 0; i < iterations_; ++i) {
        solve_pass(bodies_, i, AllPoints{});
        angular_sweep(bodies_, i, AllPoints{});
    }
}

void RigidSolver::solve_angular(const Point& p, AngularRows& r, Bodies& bodies, bool build) const {
    SolverBody& a = bodies[p.sa];
    SolverBody& b = bodies[p.sb];
    const bool move_a = a.inv_mass.raw != 0, move_b = b.inv_mass.raw != 0;
    if (build) {
        // I^-1 d: an isotropic body's scalar times d, a box's world inverse inertia times d,
        // zero for a static body (whose inverse inertia is zero anyway). Only the rows in use
        // are built.
        const auto inertia_times = [&](const SolverBody& body, BodyId id, const Vec3& d) {
            if (body.inv_mass.raw == 0) return Vec3{};
            if (body.iso_inv_inertia.raw >= 0) return d * body.iso_inv_inertia;
            return inv_i_world_[id] * d;
        };
        // Both bodies isotropic (or static): every unit direction has the effective mass
        // 1 / (s_a + s_b), taken once (spheres, the common case: one division, not three).
        const auto iso = [](const SolverBody& body) { return body.inv_mass.raw == 0 ? Fixed::zero() : body.iso_inv_inertia; };
        const Fixed sa = iso(a), sb = iso(b);
        const bool isotropic = sa.raw >= 0 && sb.raw >= 0;
        const Fixed iso_inv = sa + sb;
        const Fixed iso_mass = isotropic && iso_inv.raw > 0 ? reciprocal(iso_inv) : Fixed::zero();
        const Vec3* dirs[3] = {&p.n, &p.t1, &p.t2};
        for (int k = spin_mu_.raw > 0 ? 0 : 1; k < (roll_mu_.raw > 0 ? 3 : 1); ++k) {
            const Vec3& d = *dirs[k];
            r.ia[k] = inertia_times(a, p.a, d);
            r.ib[k] = inertia_times(b, p.b, d);
            if (isotropic) {
                r.mass[k] = iso_mass;
            } else {
                const Fixed inv = dot(d, r.ia[k]) + dot(d, r.ib[k]);
                r.mass[k] = inv.raw > 0 ? reciprocal(inv) : Fixed::zero();
            }
        }
        r.acc[0] = r.acc[1] = r.acc[2] = Fixed::zero();
    }
    // Not pressing and nothing accumulated: every bound is 0 and no impulse to take back (most
    // speculative points).
    if (p.pn.raw == 0 && r.acc[0].raw == 0 && r.acc[1].raw == 0 && r.acc[2].raw == 0) return;
    const auto apply = [&](int k, Fixed l) {
        if (move_a) a.w -= r.ia[k] * l;
        if (move_b) b.w += r.ib[k] * l;
    };
    if (spin_mu_.raw > 0) {
        const Fixed limit = spin_mu_ * p.pn;
        Fixed l = r.acc[0] - r.mass[0] * dot(p.n, b.w - a.w);
        if (l > limit) l = limit;
        if (l < -limit) l = -limit;
        const Fixed d = l - r.acc[0];
        r.acc[0] = l;
        if (d.raw != 0) apply(0, d);
    }
    if (roll_mu_.raw > 0) {
        const Fixed limit = roll_mu_ * p.pn;
        const Vec3 dw = b.w - a.w;
        Fixed l1 = r.acc[1] - r.mass[1] * dot(p.t1, dw);
        Fixed l2 = r.acc[2] - r.mass[2] * dot(p.t2, dw);
        // The disc, as the Coulomb cone is clamped (solve_point): exact squares in 128 bits.
        const u128 mag_sq = static_cast<u128>(mul_wide(l1.raw, l1.raw)) + static_cast<u128>(mul_wide(l2.raw, l2.raw));
        if (mag_sq > static_cast<u128>(mul_wide(limit.raw, limit.raw))) {
            const Fixed mag = sqrt_wide(mag_sq);
            const Fixed scale = limit / mag;  // mag > limit >= 0
            l1 = l1 * scale;
            l2 = l2 * scale;
        }
        const Fixed d1 = l1 - r.acc[1], d2 = l2 - r.acc[2];
        r.acc[1] = l1;
        r.acc[2] = l2;
        if (d1.raw != 0) apply(1, d1);
        if (d2.raw != 0) apply(2, d2);
    }
}

}  // namespace lockroll::sim
