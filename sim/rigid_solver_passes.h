// RigidSolver's passes over the contact points (sim/rigid_solver.h), as templates over which
// points they visit: every point (AllPoints, the sequential step), one island's manifolds
// (ManifoldSet, the parallel step) or a run of a coloured scene's manifolds (ManifoldRange).
// Included by rigid_solver.cpp, which instantiates them for AllPoints only (as does
// rigid_solver_angular_friction.cpp, for the spinning and rolling rows' own loop), by
// rigid_solver_parallel.cpp for ManifoldSet only and by rigid_solver_coloured.cpp for
// ManifoldRange only: the sequential step's file then holds the loops it ran before the
// parallel step existed, and its inlining is not shared with the other versions
// (docs/performance.md, "Workers off").
// Not installed; include nowhere else.
#pragma once

#include <algorithm>

#include "sim/rigid_solver.h"

namespace lockroll::sim {

template <class F>
void RigidSolver::each_point(AllPoints, bool backwards, F&& f) {
    if (backwards)
        for (auto it = points_.rbegin(); it != points_.rend(); ++it) f(*it);
    else
        for (Point& p : points_) f(p);
}

// The island's points are whole manifolds, each contiguous in points_: the subsequence of the
// global order (or of its reverse) that lies in the island.
template <class F>
void RigidSolver::each_point(ManifoldSet set, bool backwards, F&& f) {
    if (backwards) {
        for (std::size_t k = set.size(); k-- > 0;) {
            const std::uint32_t m = set[k];
            for (std::uint32_t j = manifold_start_[m + 1]; j-- > manifold_start_[m];) f(points_[j]);
        }
    } else {
        for (const std::uint32_t m : set)
            for (std::uint32_t j = manifold_start_[m]; j < manifold_start_[m + 1]; ++j) f(points_[j]);
    }
}

template <class F>
void RigidSolver::each_point(ManifoldRange range, bool backwards, F&& f) {
    const std::uint32_t begin = manifold_start_[range.begin], end = manifold_start_[range.end];
    if (backwards)
        for (std::uint32_t j = end; j-- > begin;) f(points_[j]);
    else
        for (std::uint32_t j = begin; j < end; ++j) f(points_[j]);
}

// f(begin, end) over runs of contiguous points: together what each_point(points, false) visits,
// in its order.
template <class F>
void RigidSolver::each_run(AllPoints, F&& f) {
    f(points_.data(), points_.data() + points_.size());
}
template <class F>
void RigidSolver::each_run(ManifoldSet set, F&& f) {
    for (const std::uint32_t m : set) f(points_.data() + manifold_start_[m], points_.data() + manifold_start_[m + 1]);
}
template <class F>
void RigidSolver::each_run(ManifoldRange range, F&& f) {
    f(points_.data() + manifold_start_[range.begin], points_.data() + manifold_start_[range.end]);
}

template <class Points>
void RigidSolver::warm_start(const std::vector<ContactImpulse>& impulses, Points points) {
    if (impulses.empty()) return;
    each_point(points, false, [&](Point& p) {
        const ContactImpulse k = key_of(p);
        const auto it = std::lower_bound(impulses.begin(), impulses.end(), k, key_less);
        if (it == impulses.end() || key_less(k, *it)) return;
        p.pn = it->pn;
        p.pt1 = it->pt1;
        p.pt2 = it->pt2;
        apply(p, p.pn, p.pt1, p.pt2, bodies_);
    });
}

template <class Points>
void RigidSolver::solve_pass(Bodies& bodies, int pass, Points points) {
    if (!warm_ && !block_) {
        each_run(points, [&](Point* begin, Point* end) { solve_run(begin, end, bodies); });
        return;
    }
    // Warm-started scenes: every normal row, then every friction row, odd passes backwards.
    // Friction solved point after point within a manifold leaves a net twist (the first corner
    // always goes first), which turned every box of a stack the same way; alternating the
    // direction spreads a stack's support both ways in one iteration pair.
    const auto sweep = [&](Rows rows) {
        each_point(points, pass & 1, [&](Point& p) { solve_point(p, bodies, kEveryBody, false, rows); });
    };
    if (block_) {
        const std::size_t count = manifold_count(points);
        for (std::size_t k = 0; k < count; ++k) solve_block(manifold_at(points, pass & 1 ? count - 1 - k : k), bodies, false);
    } else {
        sweep(Rows::Normal);
    }
    sweep(Rows::Friction);
}

// Each point's rows sit at its own index in angular_rows_, so any subset of the points (an
// island, a colour's range) reaches its rows without a lookup.
// Out of line (cold when off): inlined into solve()'s loop it grew the sequential file's code
// and gcc stopped inlining solve_pass() there (90 instructions a step on paper_rigid).
template <class Points>
[[gnu::noinline]] void RigidSolver::angular_sweep(Bodies& bodies, int pass, Points points) {
    // The direction the pass's friction sweep went (solve_pass()).
    const bool backwards = (warm_ || block_) && (pass & 1) != 0;
    each_point(points, backwards, [&](Point& p) {
        solve_angular(p, angular_rows_[static_cast<std::size_t>(&p - points_.data())], bodies, pass == 0);
    });
}

template <class Points>
void RigidSolver::split_iterations(Points points) {
    const std::size_t count = block_ ? manifold_count(points) : 0;
    for (int i = 0; i < iterations_; ++i) {
        if (block_)
            for (std::size_t k = 0; k < count; ++k) solve_block(manifold_at(points, i & 1 ? count - 1 - k : k), pseudo_, true);
        else
            each_point(points, i & 1, [&](Point& p) { solve_pseudo(p); });
    }
}

}  // namespace lockroll::sim
