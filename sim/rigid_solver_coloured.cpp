// RigidSolver's graph-coloured passes (rigid.graph_colouring; sim/rigid_solver.h,
// docs/physics.md "Graph-coloured rows"). Kept out of rigid_solver.cpp, as the island passes
// are (sim/rigid_solver_parallel.cpp), so a scene without the flag runs the sequential file's
// code as it was.
#include "sim/rigid_solver.h"
#include "sim/rigid_solver_passes.h"

namespace lockroll::sim {

void RigidSolver::lay_out_colours() {
    // Solver places (slots) as nodes: the same conflicts as body ids, numbered in pair order.
    colouring_.build(slot_ids_.size(), links_);
    const std::size_t count = links_.size();
    // manifold_start_ holds each manifold's first point in pair order, then the point count:
    // the counts come from it before it is rewritten in the coloured numbering.
    placed_.resize(count);
    std::uint32_t point = 0;
    for (const std::uint32_t m : colouring_.order()) {
        placed_[m] = point;
        point += manifold_start_[m + 1] - manifold_start_[m];
    }
    for (std::size_t j = 0; j < count; ++j) manifold_start_[j] = placed_[colouring_.order()[j]];
    manifold_start_[count] = point;
    for (std::size_t g = 0; g <= GraphColouring::kGroups; ++g)
        group_start_[g] = static_cast<std::uint32_t>(colouring_.group_start(g));
}

template <class F>
void RigidSolver::each_colour(const ParallelTasks& tasks, bool backwards, F&& f) {
    constexpr std::size_t groups = GraphColouring::kGroups;  // the overflow group last
    for (std::size_t k = 0; k < groups; ++k) {
        const std::size_t g = backwards ? groups - 1 - k : k;
        const std::size_t begin = group_start_[g], end = group_start_[g + 1];
        if (begin == end) continue;
        if (g == GraphColouring::kColours) {
            // Its manifolds may share bodies: in manifold order, on this thread.
            f(ManifoldRange{begin, end});
            continue;
        }
        // No two manifolds of a colour share a dynamic body: any cut, any order, same bits.
        tasks.for_ranges(end - begin, kColourGrain,
                         [&](std::size_t b, std::size_t e) { f(ManifoldRange{begin + b, begin + e}); });
    }
}

void RigidSolver::solve_coloured(const std::vector<ContactImpulse>& impulses, const ParallelTasks& tasks) {
    if (spin_roll_) prepare_angular();
    if (warm_) each_colour(tasks, false, [&](ManifoldRange range) { warm_start(impulses, range); });
    const bool alternate = warm_ || block_;
    for (int pass = 0; pass < iterations_; ++pass)
        each_colour(tasks, alternate && (pass & 1) != 0, [&](ManifoldRange range) {
            solve_pass(bodies_, pass, range);
            if (spin_roll_) angular_sweep(bodies_, pass, range);
        });
}

void RigidSolver::split_coloured(const ParallelTasks& tasks) {
    // The layout the iterations used; odd passes backwards, groups and (which matters only in
    // the overflow) manifolds, as split_iterations() goes.
    for (int i = 0; i < iterations_; ++i) {
        const bool backwards = (i & 1) != 0;
        each_colour(tasks, backwards, [&](ManifoldRange range) {
            if (block_)
                for (std::size_t k = range.begin; k < range.end; ++k) solve_block(backwards ? range.end - 1 - (k - range.begin) : k, pseudo_, true);
            else
                each_point(range, backwards, [&](Point& p) { solve_pseudo(p); });
        });
    }
}

}  // namespace lockroll::sim
