// rigid.reduce_manifold (RigidSolver::reduce, sim/rigid_solver.h): a box-box face manifold of up
// to eight points cut to at most four, the points extreme along the contact plane's diagonals,
// with ids that stay the same while the boxes wobble so warm starting finds last step's impulses.
#include <cstdint>

#include "sim/rigid_contact.h"
#include "sim/rigid_solver.h"

namespace lockroll::sim {

namespace {
// Feature ids of a reduced manifold's points (above every id sim/rigid_contact.h makes).
constexpr std::uint8_t kFeatureReduced = 240;
}  // namespace

void RigidSolver::reduce(Manifold& m) {
    // The diagonals of the tangent basis (a fixed function of the normal): for a box resting
    // on a box's face each picks one corner of the touching patch, and keeps picking it while
    // the boxes wobble, so the id (kFeatureReduced + diagonal) finds last step's impulse.
    Vec3 t1, t2;
    rigid_detail::tangents(m.points[0].normal, t1, t2);
    const Vec3 diag[4] = {t1 + t2, t1 - t2, -(t1 + t2), t2 - t1};
    Manifold out;
    bool taken[kMaxManifold] = {};
    for (int k = 0; k < 4; ++k) {
        int best = 0;
        Fixed best_d = dot(m.points[0].point, diag[k]);
        for (int i = 1; i < m.count; ++i) {
            const Fixed d = dot(m.points[i].point, diag[k]);
            if (d > best_d) {
                best = i;
                best_d = d;
            }
        }
        if (taken[best]) continue;
        taken[best] = true;
        out.points[out.count] = m.points[best];
        out.points[out.count].feature = static_cast<std::uint8_t>(kFeatureReduced + k);
        ++out.count;
    }
    m = out;
}

}  // namespace lockroll::sim
