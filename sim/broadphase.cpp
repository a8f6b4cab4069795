#include "sim/broadphase.h"

#include <algorithm>
#include <utility>

namespace lockroll::sim {

namespace {
// Sweep and prune beats the grid until the x-sweep's candidate count grows; measured in
// bench/step_bench.cpp (docs/performance.md).
constexpr std::size_t kAutoGridThreshold = 256;

bool overlap_axis(std::int64_t ca, std::int64_t ea, std::int64_t cb, std::int64_t eb) {
    // |ca - cb| <= ea + eb, computed in 128 bits so extreme coordinates cannot wrap.
    const i128 d = static_cast<i128>(ca) - cb;
    const i128 reach = static_cast<i128>(ea) + eb;
    return d <= reach && -d <= reach;
}

bool aabb_overlap(const Vec3& pa, const Vec3& ea, const Vec3& pb, const Vec3& eb, std::int64_t margin) {
    return overlap_axis(pa.x.raw, ea.x.raw + margin, pb.x.raw, eb.x.raw) &&
           overlap_axis(pa.y.raw, ea.y.raw + margin, pb.y.raw, eb.y.raw) &&
           overlap_axis(pa.z.raw, ea.z.raw + margin, pb.z.raw, eb.z.raw);
}

std::uint32_t hash_cell(std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto h = static_cast<std::uint64_t>(x) * 0x9E3779B185EBCA87ull ^
                   static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                   static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
    return static_cast<std::uint32_t>(h >> 32);
}
}  // namespace

void Broadphase::configure(BroadphaseKind kind, std::vector<BodyId> dynamic_ids, std::vector<BodyId> static_ids,
                           Fixed max_extent, Fixed margin) {
    dynamic_ = std::move(dynamic_ids);
    static_ = std::move(static_ids);
    margin_ = margin;
    if (kind == BroadphaseKind::Auto)
        kind = dynamic_.size() < kAutoGridThreshold ? BroadphaseKind::SweepAndPrune : BroadphaseKind::Grid;
    kind_ = kind;
    order_ = dynamic_;
    // Cell edge: smallest power of two >= twice the fattened extent (one full AABB).
    const std::uint64_t need = static_cast<std::uint64_t>(std::max<std::int64_t>(1, 2 * (max_extent.raw + margin.raw)));
    cell_shift_ = 0;
    while ((std::uint64_t{1} << cell_shift_) < need && cell_shift_ < 62) ++cell_shift_;
}

void Broadphase::find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out) {
    out.clear();
    if (kind_ == BroadphaseKind::Grid)
        grid(pos, extent, out);
    else
        sweep_and_prune(pos, extent, out);
    statics(pos, extent, out);
}

void Broadphase::sweep_and_prune(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent,
                                 std::vector<BodyPair>& out) {
    if (min_x_.size() < pos.size()) min_x_.resize(pos.size());
    for (BodyId id : dynamic_) min_x_[id] = pos[id].x.raw - extent[id].x.raw - margin_.raw;
    // Insertion sort on (min x, id): near-linear frame to frame because order changes little.
    // The key is total, so the result is the same whatever order we start from.
    auto less = [&](BodyId a, BodyId b) { return min_x_[a] < min_x_[b] || (min_x_[a] == min_x_[b] && a < b); };
    for (std::size_t i = 1; i < order_.size(); ++i) {
        const BodyId v = order_[i];
        std::size_t j = i;
        for (; j > 0 && less(v, order_[j - 1]); --j) order_[j] = order_[j - 1];
        order_[j] = v;
    }
    const std::int64_t m = margin_.raw;
    for (std::size_t i = 0; i < order_.size(); ++i) {
        const BodyId a = order_[i];
        const i128 max_x = static_cast<i128>(pos[a].x.raw) + extent[a].x.raw + m;
        for (std::size_t j = i + 1; j < order_.size(); ++j) {
            const BodyId b = order_[j];
            if (min_x_[b] > max_x) break;
            if (overlap_axis(pos[a].y.raw, extent[a].y.raw + m, pos[b].y.raw, extent[b].y.raw) &&
                overlap_axis(pos[a].z.raw, extent[a].z.raw + m, pos[b].z.raw, extent[b].z.raw))
                out.push_back(a < b ? BodyPair{a, b} : BodyPair{b, a});
        }
    }
}

void Broadphase::grid(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out) {
    std::size_t table = 16;
    while (table < 2 * dynamic_.size()) table <<= 1;
    const std::uint32_t mask = static_cast<std::uint32_t>(table - 1);
    if (cell_.size() < pos.size()) {
        cell_.resize(pos.size());
        bucket_.resize(pos.size());
    }
    bucket_start_.assign(table + 1, 0);
    const std::int64_t m = margin_.raw;
    for (BodyId id : dynamic_) {
        const Cell c{(pos[id].x.raw - extent[id].x.raw - m) >> cell_shift_,
                     (pos[id].y.raw - extent[id].y.raw - m) >> cell_shift_,
                     (pos[id].z.raw - extent[id].z.raw - m) >> cell_shift_};
        cell_[id] = c;
        bucket_[id] = hash_cell(c.x, c.y, c.z) & mask;
        ++bucket_start_[bucket_[id] + 1];
    }
    for (std::size_t b = 1; b <= table; ++b) bucket_start_[b] += bucket_start_[b - 1];
    bucket_items_.resize(dynamic_.size());
    {
        // Stable fill in ascending id order: each bucket lists its bodies by id.
        std::vector<std::uint32_t>& cursor = bucket_start_;  // reuse: shift back afterwards
        for (BodyId id : dynamic_) bucket_items_[cursor[bucket_[id]]++] = id;
        for (std::size_t b = table; b > 0; --b) cursor[b] = cursor[b - 1];
        cursor[0] = 0;
    }
    // Each unordered pair of neighbouring cells is visited once: the own cell (ids above ours)
    // plus the 13 neighbours that are "forward" in (z, y, x) lexicographic order.
    static constexpr int kForward[13][3] = {{1, 0, 0},  {-1, 1, 0}, {0, 1, 0},  {1, 1, 0},   {-1, -1, 1},
                                            {0, -1, 1}, {1, -1, 1}, {-1, 0, 1}, {0, 0, 1},   {1, 0, 1},
                                            {-1, 1, 1}, {0, 1, 1},  {1, 1, 1}};
    for (BodyId a : dynamic_) {
        const Cell c = cell_[a];
        for (int k = -1; k < 13; ++k) {
            const Cell n = k < 0 ? c : Cell{c.x + kForward[k][0], c.y + kForward[k][1], c.z + kForward[k][2]};
            const std::uint32_t bucket = k < 0 ? bucket_[a] : (hash_cell(n.x, n.y, n.z) & mask);
            for (std::uint32_t s = bucket_start_[bucket]; s < bucket_start_[bucket + 1]; ++s) {
                const BodyId b = bucket_items_[s];
                if (k < 0 ? b <= a : false) continue;
                const Cell& cb = cell_[b];
                if (cb.x != n.x || cb.y != n.y || cb.z != n.z) continue;  // another cell, same bucket
                if (aabb_overlap(pos[a], extent[a], pos[b], extent[b], m))
                    out.push_back(a < b ? BodyPair{a, b} : BodyPair{b, a});
            }
        }
    }
}

void Broadphase::statics(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out) {
    for (BodyId s : static_)
        for (BodyId d : dynamic_)
            if (aabb_overlap(pos[d], extent[d], pos[s], extent[s], margin_.raw))
                out.push_back(s < d ? BodyPair{s, d} : BodyPair{d, s});
}

}  // namespace lockroll::sim
