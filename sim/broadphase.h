// Candidate pairs for a step: bodies whose AABBs, fattened by the contact margin, overlap.
//
// Output order is a pure function of the body state (positions, with ids breaking ties), never
// of history, pointer values or hash-table layout beyond what positions determine. That is what
// lets a world that loaded a snapshot produce the same pairs as one that never saved.
// Static-static pairs are never produced.
//
// At the Q32.32 limits: positions anywhere in the int64 range, extents and margin >= 0. A box
// is saturated to int64, which changes no overlap verdict (a min corner below INT64_MIN meets
// every max corner, a max corner above INT64_MAX every min corner), and both modes then find
// exactly the pairs of overlapping boxes, also for boxes on the limits themselves and for a
// grid whose bounds span the whole range (tests/sim/broadphase_test.cpp, "The Q32.32 limits").
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sim/parallel_tasks.h"
#include "sim/scene.h"

namespace lockroll::sim {

struct BodyPair {
    BodyId a, b;
};

class Broadphase {
public:
    // ids must be ascending; extent[id] is each body's AABB half size (fixed for its life).
    // pos gives the initial positions, from which the grid's bounds are taken.
    void configure(BroadphaseKind kind, std::vector<BodyId> dynamic_ids, std::vector<BodyId> static_ids,
                   const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, Fixed margin);

    // tasks: how the box update, the grid walk and the static tests run; the pairs and their
    // order are the same either way (each range of work into its own list, concatenated in
    // the canonical order).
    void find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out,
                    const ParallelTasks& tasks = ParallelTasks());

    BroadphaseKind kind() const { return kind_; }

private:
    // Fattened AABB of one body, saturated to int64 once per step so every overlap test after
    // that is six plain comparisons.
    struct Box {
        std::int64_t lo[3], hi[3];
    };
    static Box make_box(const Vec3& pos, const Vec3& extent, std::int64_t margin);
    static bool overlap(const Box& a, const Box& b) {
        return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
               a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
    }
    // The same test without branches, 1 or 0.
    static std::uint32_t overlap_bits(const Box& a, const Box& b) {
        return static_cast<std::uint32_t>((a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) &
                                          (b.lo[1] <= a.hi[1]) & (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]));
    }

    void sweep_and_prune(std::vector<BodyPair>& out);
    // keys_ready: keys_ already holds every gridded body's key (find_pairs' sequential box loop).
    void grid(std::vector<BodyPair>& out, const ParallelTasks& tasks, bool keys_ready);
    // The grid walk over occupied_[first, last), into scratch_[piece] in walk order; returns
    // how many pairs it found.
    std::uint32_t walk(std::size_t first, std::size_t last, std::uint32_t piece);
    // Interior cell coordinate 1..dims along axis k of a box's min corner (0 and dims + 1 are
    // the empty border).
    // Inline (it was a lambda in grid(); out of line it cost bodies_10k's step ~4 %).
    // Clamped before the origin is subtracted: at a cell edge of 1 raw unit, a min corner at
    // one int64 limit minus an origin of the other sign overflows.
    std::int64_t coord(const Box& box, int k) const {
        return std::clamp(box.lo[k] >> cell_shift_, origin_[k], last_[k]) - origin_[k] + 1;
    }
    void oversize_and_statics(std::vector<BodyPair>& out, const ParallelTasks& tasks);
    // The radix sort key of a gridded body: its box's linear cell index << 32 | id.
    std::uint64_t key(BodyId id) const {
        const Box& box = box_[id];
        const auto c = static_cast<std::uint64_t>(coord(box, 2) * stride_z_ + coord(box, 1) * stride_y_ + coord(box, 0));
        return c << 32 | id;
    }
    static constexpr int kDigit = 11;  // radix sort: bits a pass
    static constexpr std::uint32_t kBuckets = 1u << kDigit;
    static std::uint32_t digit(std::uint64_t key, int shift) {
        return static_cast<std::uint32_t>(key >> (32 + shift)) & (kBuckets - 1);
    }
    // grid()'s sort and layout cut into `pieces` ranges (the parallel step): the same keys_,
    // sorted_id_, sorted_box_, cell_ and occupied_ as the sequential loops.
    void sort_and_layout(std::size_t pieces, const ParallelTasks& tasks);

    // Work per parallel range, at least: bodies, occupied cells, static-dynamic tests.
    static constexpr std::size_t kGrain = 1024, kCellGrain = 256, kStaticGrain = 8192;
    // Sequential static tests: dynamic bodies a block (their boxes: 24 KB, within L1).
    static constexpr std::size_t kStaticBlock = 512;

    BroadphaseKind kind_ = BroadphaseKind::SweepAndPrune;
    std::vector<BodyId> dynamic_, static_;
    // Grid only: dynamic bodies too large for the cell size; tested against every dynamic body.
    std::vector<BodyId> gridded_, oversize_;
    Fixed margin_;
    std::vector<Box> box_;         // by body id; statics filled once in configure()
    std::vector<Box> static_box_;  // the static bodies' boxes in static_ order (the walk's static tests)
    bool statics_ready_ = false;

    // Sweep and prune: dynamic ids sorted by (min x, id). Kept between steps only to make the
    // insertion sort cheap; the sorted result does not depend on the previous order.
    std::vector<BodyId> order_;

    // Uniform dense grid over the scene's bounds (static geometry and initial bodies): cell
    // edge 2^cell_shift_ raw units, at least the fattened AABB of every gridded body, so
    // overlapping bodies sit in the same or adjacent cells (by min corner). The edge follows
    // the 95th-percentile body so one big body cannot coarsen the grid. Bodies outside the
    // bounds are clamped into the border cells: clamping keeps neighbours neighbours, so it
    // only costs extra tests, never a missed pair.
    // The grid has a one-cell empty border on every side, so a neighbour is always
    // cell + offset, with no bounds test. Only occupied cells are filled and cleared, so a
    // step costs O(bodies), however many cells the bounds span.
    int cell_shift_ = 0;
    std::int64_t origin_[3] = {0, 0, 0};
    std::int64_t dims_[3] = {1, 1, 1};    // interior cells per axis (the border comes on top)
    std::int64_t last_[3] = {0, 0, 0};    // origin_ + dims_ - 1 (the last interior cell's lo >> shift)
    std::int64_t stride_y_ = 0, stride_z_ = 0;
    i128 widest_ = 0;  // widest fattened box (hi - lo) of a gridded body, any axis
    i128 down_reach_ = 0;  // widest_ - 1: the walk's reach into the row below (once, not per cell)
    int key_bits_ = 0;  // bits of the largest linear cell index (< 2^32: radix sort passes)

    // Spatially ordered layout, rebuilt each step: gridded bodies radix-sorted by linear cell
    // index (stable, so ascending id within a cell), their boxes copied into that order, so
    // a cell's bodies are contiguous and cells are walked in memory order.
    // Slots [start, end) in sorted_id_ / sorted_box_. An empty cell (any cell outside
    // occupied_) is {UINT32_MAX, 0}, so the bodies of a run of cells are [min start, max end)
    // with no test for empty cells (a branch on occupancy was a coin toss in a sparse grid).
    struct Cell {
        std::uint32_t start, end;
    };
    static constexpr Cell kEmptyCell{UINT32_MAX, 0};
    // Body a (box ba) against the static bodies in near (bit i: static_[i]; every static body
    // when there are more than 64): its static pairs, static order, written at w[used...] (room
    // reserved); returns the new count. Out of line: most bodies' cells reach no static body.
    [[gnu::noinline]] std::uint32_t static_tests(BodyId a, const Box& ba, std::uint64_t near, BodyPair* w,
                                                 std::uint32_t used) const;
    std::vector<Cell> cell_;                 // by linear cell index
    std::vector<std::uint32_t> occupied_;    // cells with bodies this step, ascending index
    std::vector<std::uint64_t> keys_, keys_tmp_;  // (cell << 32 | id) for the radix sort
    std::vector<BodyId> sorted_id_;          // body in each slot
    std::vector<Box> sorted_box_;            // its box, copied so neighbour scans are contiguous
    std::vector<std::vector<BodyPair>> scratch_;  // per walk range: pairs as found, by the body whose walk found them
    std::vector<std::uint32_t> found_;       // per walk range: how many
    std::vector<std::uint64_t> static_mask_[3];  // per axis, by cell coordinate: static bodies in reach (at most 64)
    std::vector<std::vector<BodyPair>> static_pairs_;  // per range of static-dynamic tests (sequential: per static body)
    std::vector<std::uint32_t> histograms_;  // parallel sort: kBuckets counters per range
    std::vector<std::vector<std::uint32_t>> occupied_parts_;  // parallel layout: occupied cells per range
};

}  // namespace lockroll::sim
