// The parallel step's phases of RigidSolver (sim/rigid_solver.h), kept out of rigid_solver.cpp
// so that the sequential step's file holds only what a workers-off step runs. With them in the
// same file gcc 12 ran out of its per-file inlining budget (--param inline-unit-growth) and
// called round_wide, dot and the per-point helpers out of line from the sequential loops:
// paper_rigid's step ran 3 % more instructions than before the parallel step
// (docs/performance.md, "Workers off"). The per-range work of contact generation
// (find_manifolds, build_found) stays in rigid_solver.cpp, which inlines the per-pair code.
#include <algorithm>

#include "sim/grow.h"
#include "sim/rigid_solver.h"
#include "sim/rigid_solver_passes.h"

namespace lockroll::sim {

void RigidSolver::build_contacts_parallel(const std::vector<Vec3>& pos, const std::vector<Vec3>& vel,
                                          const std::vector<Vec3>& angvel, const ParallelTasks& tasks) {
    for (BodyId id : slot_ids_) slot_[id] = kNoSlot;
    slot_ids_.clear();
    bodies_.clear();
    points_.clear();
    manifold_start_.clear();
    links_.clear();
    // 1. Manifolds per range of pairs (contiguous ranges, so the lists concatenated in range
    //    order are the pairs' order).
    const std::size_t n = pairs_.size();
    const std::size_t pieces = tasks.piece_count(n, kPairGrain);
    if (found_.size() < pieces) found_.resize(pieces);
    tasks.run(pieces, [&](std::size_t k) { find_manifolds(n * k / pieces, n * (k + 1) / pieces, pos, found_[k]); });
    // 2. Slots and places in the order the sequential step makes them: manifold by manifold.
    //    Only the numbering is sequential; the solver bodies are copied in per range after.
    const auto place_of = [this](BodyId id) {
        std::uint32_t& slot = slot_[id];
        if (slot == kNoSlot) {
            slot = static_cast<std::uint32_t>(slot_ids_.size());
            slot_ids_.push_back(id);
        }
        return slot;
    };
    found_first_.resize(pieces + 1);
    std::size_t point_count = 0;
    for (std::size_t k = 0; k < pieces; ++k) {
        found_first_[k] = static_cast<std::uint32_t>(manifold_start_.size());
        for (const Found& f : found_[k]) {
            const BodyPair& pair = pairs_[f.pair];
            const bool swapped = shape_[pair.a] == Shape::Box && shape_[pair.b] != Shape::Box;
            const BodyId a = swapped ? pair.b : pair.a, b = swapped ? pair.a : pair.b;
            const std::uint32_t sa = place_of(a), sb = place_of(b);
            manifold_start_.push_back(static_cast<std::uint32_t>(point_count));
            links_.push_back({inv_mass_[a].raw != 0 ? sa : Islands::kStatic, inv_mass_[b].raw != 0 ? sb : Islands::kStatic});
            point_count += static_cast<std::size_t>(f.m.count);
        }
    }
    found_first_[pieces] = static_cast<std::uint32_t>(manifold_start_.size());
    manifold_start_.push_back(static_cast<std::uint32_t>(point_count));
    if (colour_) lay_out_colours();
    // Sized once, without zero-filling (points_' allocator): build_found writes each point
    // whole, in parallel, where a value-initialising resize here was a sequential memset of
    // every point (several MB a step in bodies_10k_rigid). Both buffers were cleared above:
    // grow(), not resize(), or a count that creeps up step by step reallocates every step
    // (sim/grow.h).
    grow(points_, point_count);
    // 2b. The solver bodies, per range of places: what slot_of() copies in the sequential step.
    grow(bodies_, slot_ids_.size());
    tasks.for_ranges(slot_ids_.size(), kBodyGrain, [&](std::size_t begin, std::size_t end) {
        for (std::size_t k = begin; k < end; ++k) {
            const BodyId id = slot_ids_[k];
            const Fixed iso = isotropic_[id] ? inv_inertia_[id].x : -Fixed::one();
            bodies_[k] = {vel[id], angvel[id], inv_mass_[id], iso};
        }
    });
    // 3. The points, per range, into their places (they read only the slots made in 2).
    const std::vector<std::uint32_t>& place = colour_ ? placed_ : manifold_start_;
    tasks.run(pieces, [&](std::size_t k) { build_found(found_[k], found_first_[k], place, pos); });
}

void RigidSolver::scatter_parallel(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, const ParallelTasks& tasks) const {
    tasks.for_ranges(bodies_.size(), kBodyGrain, [&](std::size_t begin, std::size_t end) {
        for (std::size_t k = begin; k < end; ++k) {
            if (bodies_[k].inv_mass.raw == 0) continue;
            vel[slot_ids_[k]] = bodies_[k].v;
            angvel[slot_ids_[k]] = bodies_[k].w;
        }
    });
}

void RigidSolver::solve_islands(const std::vector<ContactImpulse>& impulses, const ParallelTasks& tasks) {
    islands_.build(bodies_.size(), links_, tasks);
    if (spin_roll_) prepare_angular();
    const std::size_t pieces = std::min(tasks.piece_count(links_.size(), kManifoldGrain), islands_.count());
    tasks.run(pieces, [&](std::size_t k) {
        for (std::size_t i = islands_.first(pieces, k), e = islands_.first(pieces, k + 1); i < e; ++i) {
            const ManifoldSet set = islands_.links(i);
            if (warm_) warm_start(impulses, set);
            for (int pass = 0; pass < iterations_; ++pass) {
                solve_pass(bodies_, pass, set);
                if (spin_roll_) angular_sweep(bodies_, pass, set);
            }
        }
    });
}

void RigidSolver::split_islands(const ParallelTasks& tasks) {
    // The same islands as the iterations (solve_islands built them this step).
    const std::size_t pieces = std::min(tasks.piece_count(links_.size(), kManifoldGrain), islands_.count());
    tasks.run(pieces, [&](std::size_t k) {
        for (std::size_t i = islands_.first(pieces, k), e = islands_.first(pieces, k + 1); i < e; ++i) {
            split_iterations(ManifoldSet(islands_.links(i)));
        }
    });
}

}  // namespace lockroll::sim
