// Candidate pairs for a step: bodies whose AABBs, fattened by the contact margin, overlap.
//
// Output order is a pure function of the body state (positions, with ids breaking ties), never
// of history, pointer values or hash-table layout beyond what positions determine. That is what
// lets a world that loaded a snapshot produce the same pairs as one that never saved.
// Static-static pairs are never produced.
#pragma once

#include <cstdint>
#include <vector>

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

    void find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out);

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

    void sweep_and_prune(std::vector<BodyPair>& out);
    void grid(std::vector<BodyPair>& out);
    void oversize_and_statics(std::vector<BodyPair>& out);

    BroadphaseKind kind_ = BroadphaseKind::SweepAndPrune;
    std::vector<BodyId> dynamic_, static_;
    // Grid only: dynamic bodies too large for the cell size; tested against every dynamic body.
    std::vector<BodyId> gridded_, oversize_;
    Fixed margin_;
    std::vector<Box> box_;         // by body id; statics filled once in configure()
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
    // cell + offset, with no bounds test. Only occupied cells are counted and cleared, so a
    // step costs O(bodies), however many cells the bounds span.
    int cell_shift_ = 0;
    std::int64_t origin_[3] = {0, 0, 0};
    std::int64_t dims_[3] = {1, 1, 1};    // interior cells per axis (the border comes on top)
    std::int64_t stride_y_ = 0, stride_z_ = 0;
    std::int64_t forward_offset_[13] = {};  // linear offsets of the 13 forward neighbours
    // Per forward neighbour, the reach it needs: bit k for +1 along axis k, bit 3 + k for -1.
    std::uint8_t forward_need_[13] = {};
    i128 widest_ = 0;  // widest fattened box (hi - lo) of a gridded body, any axis
    std::vector<std::uint32_t> cell_count_;  // bodies per cell; zero outside occupied_
    std::vector<std::uint32_t> cell_start_;  // first slot in cell_items_, valid when count > 0
    std::vector<std::uint32_t> occupied_;    // cells with bodies this step, by first body id
    std::vector<BodyId> cell_items_;         // gridded bodies grouped by cell, ascending id within
    std::vector<std::uint32_t> cell_of_;     // linear cell index by body id
    std::vector<std::uint32_t> slot_of_;     // index in cell_items_ by body id
};

}  // namespace lockroll::sim
