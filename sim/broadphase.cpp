#include "sim/broadphase.h"

#include <algorithm>
#include <utility>

namespace lockroll::sim {

namespace {
// Sweep and prune beats the grid until the x-sweep's candidate count grows; measured in
// bench/step_bench.cpp (docs/performance.md).
constexpr std::size_t kAutoGridThreshold = 2048;

std::int64_t sat(i128 v) {
    return v > INT64_MAX ? INT64_MAX : v < INT64_MIN ? INT64_MIN : static_cast<std::int64_t>(v);
}

std::uint32_t hash_cell(std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto h = static_cast<std::uint64_t>(x) * 0x9E3779B185EBCA87ull ^
                   static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                   static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
    return static_cast<std::uint32_t>(h >> 32);
}

std::int64_t largest_axis(const Vec3& e) { return std::max({e.x.raw, e.y.raw, e.z.raw}); }
}  // namespace

Broadphase::Box Broadphase::make_box(const Vec3& p, const Vec3& e, std::int64_t m) {
    Box b;
    const Fixed c[3] = {p.x, p.y, p.z}, h[3] = {e.x, e.y, e.z};
    for (int k = 0; k < 3; ++k) {
        const i128 reach = static_cast<i128>(h[k].raw) + m;
        b.lo[k] = sat(static_cast<i128>(c[k].raw) - reach);
        b.hi[k] = sat(static_cast<i128>(c[k].raw) + reach);
    }
    return b;
}

void Broadphase::configure(BroadphaseKind kind, std::vector<BodyId> dynamic_ids, std::vector<BodyId> static_ids,
                           const std::vector<Vec3>& extent, Fixed margin) {
    dynamic_ = std::move(dynamic_ids);
    static_ = std::move(static_ids);
    margin_ = margin;
    if (kind == BroadphaseKind::Auto)
        kind = dynamic_.size() < kAutoGridThreshold ? BroadphaseKind::SweepAndPrune : BroadphaseKind::Grid;
    kind_ = kind;
    order_ = dynamic_;
    box_.assign(extent.size(), Box{});
    statics_ready_ = false;

    // Grid cell edge from the 95th-percentile extent; larger bodies go to the oversize list.
    gridded_.clear();
    oversize_.clear();
    if (dynamic_.empty()) return;
    std::vector<std::int64_t> sizes;
    for (BodyId id : dynamic_) sizes.push_back(largest_axis(extent[id]));
    std::sort(sizes.begin(), sizes.end());
    const std::int64_t typical = sizes[(sizes.size() - 1) * 95 / 100];
    const auto need = static_cast<std::uint64_t>(std::max<std::int64_t>(1, sat(2 * (static_cast<i128>(typical) + margin.raw))));
    cell_shift_ = 0;
    while ((std::uint64_t{1} << cell_shift_) < need && cell_shift_ < 62) ++cell_shift_;
    for (BodyId id : dynamic_) (largest_axis(extent[id]) > typical ? oversize_ : gridded_).push_back(id);
}

void Broadphase::find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out) {
    out.clear();
    if (!statics_ready_) {  // statics never move: their boxes are computed once
        for (BodyId id : static_) box_[id] = make_box(pos[id], extent[id], 0);
        statics_ready_ = true;
    }
    for (BodyId id : dynamic_) box_[id] = make_box(pos[id], extent[id], margin_.raw);
    if (kind_ == BroadphaseKind::Grid)
        grid(out);
    else
        sweep_and_prune(out);
    oversize_and_statics(out);
}

void Broadphase::sweep_and_prune(std::vector<BodyPair>& out) {
    // Insertion sort on (min x, id): near-linear frame to frame because order changes little.
    // The key is total, so the result is the same whatever order we start from.
    auto less = [&](BodyId a, BodyId b) {
        return box_[a].lo[0] < box_[b].lo[0] || (box_[a].lo[0] == box_[b].lo[0] && a < b);
    };
    for (std::size_t i = 1; i < order_.size(); ++i) {
        const BodyId v = order_[i];
        std::size_t j = i;
        for (; j > 0 && less(v, order_[j - 1]); --j) order_[j] = order_[j - 1];
        order_[j] = v;
    }
    for (std::size_t i = 0; i < order_.size(); ++i) {
        const BodyId a = order_[i];
        const Box& ba = box_[a];
        for (std::size_t j = i + 1; j < order_.size(); ++j) {
            const BodyId b = order_[j];
            const Box& bb = box_[b];
            if (bb.lo[0] > ba.hi[0]) break;
            if (ba.lo[1] <= bb.hi[1] && bb.lo[1] <= ba.hi[1] && ba.lo[2] <= bb.hi[2] && bb.lo[2] <= ba.hi[2])
                out.push_back(a < b ? BodyPair{a, b} : BodyPair{b, a});
        }
    }
}

void Broadphase::grid(std::vector<BodyPair>& out) {
    std::size_t table = 16;
    while (table < 2 * gridded_.size()) table <<= 1;
    const auto mask = static_cast<std::uint32_t>(table - 1);
    if (cell_.size() < box_.size()) {
        cell_.resize(box_.size());
        bucket_.resize(box_.size());
    }
    bucket_start_.assign(table + 1, 0);
    for (BodyId id : gridded_) {
        const Cell c{box_[id].lo[0] >> cell_shift_, box_[id].lo[1] >> cell_shift_, box_[id].lo[2] >> cell_shift_};
        cell_[id] = c;
        bucket_[id] = hash_cell(c.x, c.y, c.z) & mask;
        ++bucket_start_[bucket_[id] + 1];
    }
    for (std::size_t b = 1; b <= table; ++b) bucket_start_[b] += bucket_start_[b - 1];
    bucket_items_.resize(gridded_.size());
    // Stable fill in ascending id order, so each bucket lists its bodies by id; the cursor pass
    // shifts the offsets by one bucket, which the loop after it undoes.
    for (BodyId id : gridded_) bucket_items_[bucket_start_[bucket_[id]]++] = id;
    for (std::size_t b = table; b > 0; --b) bucket_start_[b] = bucket_start_[b - 1];
    bucket_start_[0] = 0;

    // Each unordered pair of neighbouring cells is visited once: the own cell (ids above ours)
    // plus the 13 neighbours that are "forward" in (z, y, x) lexicographic order.
    static constexpr int kForward[13][3] = {{1, 0, 0},  {-1, 1, 0}, {0, 1, 0},  {1, 1, 0},   {-1, -1, 1},
                                            {0, -1, 1}, {1, -1, 1}, {-1, 0, 1}, {0, 0, 1},   {1, 0, 1},
                                            {-1, 1, 1}, {0, 1, 1},  {1, 1, 1}};
    for (BodyId a : gridded_) {
        const Cell c = cell_[a];
        const Box& ba = box_[a];
        for (int k = -1; k < 13; ++k) {
            const Cell n = k < 0 ? c : Cell{c.x + kForward[k][0], c.y + kForward[k][1], c.z + kForward[k][2]};
            const std::uint32_t bucket = k < 0 ? bucket_[a] : (hash_cell(n.x, n.y, n.z) & mask);
            for (std::uint32_t s = bucket_start_[bucket]; s < bucket_start_[bucket + 1]; ++s) {
                const BodyId b = bucket_items_[s];
                if (k < 0 && b <= a) continue;
                const Cell& cb = cell_[b];
                if (cb.x != n.x || cb.y != n.y || cb.z != n.z) continue;  // another cell, same bucket
                if (overlap(ba, box_[b])) out.push_back(a < b ? BodyPair{a, b} : BodyPair{b, a});
            }
        }
    }
}

void Broadphase::oversize_and_statics(std::vector<BodyPair>& out) {
    if (kind_ == BroadphaseKind::Grid) {
        // Oversize bodies against every dynamic body (each oversize-oversize pair once).
        for (BodyId o : oversize_)
            for (BodyId d : dynamic_) {
                if (d == o) continue;
                const bool other_oversize = std::binary_search(oversize_.begin(), oversize_.end(), d);
                if (other_oversize && d < o) continue;
                if (overlap(box_[o], box_[d])) out.push_back(o < d ? BodyPair{o, d} : BodyPair{d, o});
            }
    }
    for (BodyId s : static_) {
        const Box& bs = box_[s];
        for (BodyId d : dynamic_)
            if (overlap(bs, box_[d])) out.push_back(s < d ? BodyPair{s, d} : BodyPair{d, s});
    }
}

}  // namespace lockroll::sim
