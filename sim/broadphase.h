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
    // ids must be ascending. max_extent is the largest dynamic AABB half size on any axis.
    void configure(BroadphaseKind kind, std::vector<BodyId> dynamic_ids, std::vector<BodyId> static_ids,
                   Fixed max_extent, Fixed margin);

    void find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out);

    BroadphaseKind kind() const { return kind_; }

private:
    void sweep_and_prune(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out);
    void grid(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out);
    void statics(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out);

    BroadphaseKind kind_ = BroadphaseKind::SweepAndPrune;
    std::vector<BodyId> dynamic_, static_;
    Fixed margin_;

    // Sweep and prune: dynamic ids sorted by (min x, id). Kept between steps only to make the
    // insertion sort cheap; the sorted result does not depend on the previous order.
    std::vector<BodyId> order_;
    std::vector<std::int64_t> min_x_;  // by body id

    // Uniform grid: cell edge 2^cell_shift_ raw units, at least the largest fattened AABB, so
    // overlapping bodies sit in the same or adjacent cells (by their min corner).
    int cell_shift_ = 0;
    std::vector<std::uint32_t> bucket_start_;  // counting-sort offsets, size table + 1
    std::vector<BodyId> bucket_items_;
    struct Cell { std::int64_t x, y, z; };
    std::vector<Cell> cell_;  // by body id
    std::vector<std::uint32_t> bucket_;  // by body id
};

}  // namespace lockroll::sim
