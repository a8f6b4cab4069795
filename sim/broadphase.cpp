#include "sim/broadphase.h"

#include <algorithm>
#include <utility>

namespace lockroll::sim {

namespace {
// Sweep and prune beats the grid until the x-sweep's candidate count grows; measured in
// bench/step_bench.cpp (docs/performance.md).
constexpr std::size_t kAutoGridThreshold = 512;

std::int64_t sat(i128 v) {
    return v > INT64_MAX ? INT64_MAX : v < INT64_MIN ? INT64_MIN : static_cast<std::int64_t>(v);
}

std::int64_t largest_axis(const Vec3& e) { return std::max({e.x.raw, e.y.raw, e.z.raw}); }

// Each unordered pair of neighbouring cells is visited once: the own cell (ids above ours) plus
// the 13 neighbours that are "forward" in (z, y, x) lexicographic order.
constexpr int kForward[13][3] = {{1, 0, 0},  {-1, 1, 0}, {0, 1, 0},  {1, 1, 0},  {-1, -1, 1}, {0, -1, 1}, {1, -1, 1},
                                 {-1, 0, 1}, {0, 0, 1},  {1, 0, 1},  {-1, 1, 1}, {0, 1, 1},   {1, 1, 1}};
}  // namespace

Broadphase::Box Broadphase::make_box(const Vec3& p, const Vec3& e, std::int64_t m) {
    Box b;
    const std::int64_t c[3] = {p.x.raw, p.y.raw, p.z.raw}, h[3] = {e.x.raw, e.y.raw, e.z.raw};
    for (int k = 0; k < 3; ++k) {
        // Plain int64 unless something overflows (only near the Q32.32 limits); then saturate.
        std::int64_t reach, lo, hi;
        if (add_overflow(h[k], m, &reach) || sub_overflow(c[k], reach, &lo) || add_overflow(c[k], reach, &hi)) {
            const i128 wide = static_cast<i128>(h[k]) + m;
            lo = sat(static_cast<i128>(c[k]) - wide);
            hi = sat(static_cast<i128>(c[k]) + wide);
        }
        b.lo[k] = lo;
        b.hi[k] = hi;
    }
    return b;
}

void Broadphase::configure(BroadphaseKind kind, std::vector<BodyId> dynamic_ids, std::vector<BodyId> static_ids,
                           const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, Fixed margin) {
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

    // Bounds: everything static plus every body's starting box.
    Box bounds = make_box(pos[dynamic_[0]], extent[dynamic_[0]], margin.raw);
    auto grow = [&](const Box& b) {
        for (int k = 0; k < 3; ++k) {
            bounds.lo[k] = std::min(bounds.lo[k], b.lo[k]);
            bounds.hi[k] = std::max(bounds.hi[k], b.hi[k]);
        }
    };
    for (BodyId id : dynamic_) grow(make_box(pos[id], extent[id], margin.raw));
    for (BodyId id : static_) grow(make_box(pos[id], extent[id], 0));
    // Coarsen until the grid has at most ~16 cells per body (memory and clearing cost).
    const std::uint64_t max_cells = std::max<std::uint64_t>(4096, 64 * gridded_.size());
    for (;;) {
        std::uint64_t cells = 1;
        for (int k = 0; k < 3; ++k) {
            origin_[k] = bounds.lo[k] >> cell_shift_;
            dims_[k] = (bounds.hi[k] >> cell_shift_) - origin_[k] + 1;
            cells *= static_cast<std::uint64_t>(dims_[k]);
        }
        if (cells <= max_cells || cell_shift_ >= 62) break;
        ++cell_shift_;
    }
    const std::int64_t px = dims_[0] + 2, py = dims_[1] + 2, pz = dims_[2] + 2;  // with the border
    stride_y_ = px;
    stride_z_ = px * py;
    for (int k = 0; k < 13; ++k) {
        forward_offset_[k] = kForward[k][0] + kForward[k][1] * stride_y_ + kForward[k][2] * stride_z_;
        forward_need_[k] = 0;
        for (int j = 0; j < 3; ++j)
            if (kForward[k][j] != 0) forward_need_[k] |= static_cast<std::uint8_t>((kForward[k][j] > 0 ? 1u : 8u) << j);
    }
    // Widest fattened box of a gridded body on any axis (hi - lo, as make_box builds it).
    widest_ = 0;
    for (BodyId id : gridded_) {
        const Box b = make_box(Vec3{}, extent[id], margin.raw);
        for (int k = 0; k < 3; ++k) widest_ = std::max(widest_, static_cast<i128>(b.hi[k]) - b.lo[k]);
    }
    cell_count_.assign(static_cast<std::size_t>(px * py * pz), 0);
    cell_start_.assign(cell_count_.size(), 0);
    occupied_.clear();
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
    // Interior coordinates 1..dims (0 and dims + 1 are the empty border).
    auto coord = [&](BodyId id, int k) {
        return std::clamp((box_[id].lo[k] >> cell_shift_) - origin_[k], std::int64_t{0}, dims_[k] - 1) + 1;
    };
    for (std::uint32_t c : occupied_) cell_count_[c] = 0;
    occupied_.clear();
    if (cell_of_.size() < box_.size()) {
        cell_of_.resize(box_.size());
        slot_of_.resize(box_.size());
    }
    for (BodyId id : gridded_) {
        const auto c = static_cast<std::uint32_t>(coord(id, 2) * stride_z_ + coord(id, 1) * stride_y_ + coord(id, 0));
        cell_of_[id] = c;
        if (cell_count_[c]++ == 0) occupied_.push_back(c);
    }
    // Slots per occupied cell, in order of first appearance; then a stable fill by id, so each
    // cell lists its bodies in ascending id order.
    std::uint32_t next = 0;
    for (std::uint32_t c : occupied_) {
        cell_start_[c] = next;
        next += cell_count_[c];
    }
    cell_items_.resize(gridded_.size());
    for (BodyId id : gridded_) {
        const std::uint32_t slot = cell_start_[cell_of_[id]]++;
        cell_items_[slot] = id;
        slot_of_[id] = slot;
    }
    for (std::uint32_t c : occupied_) cell_start_[c] -= cell_count_[c];

    for (BodyId a : gridded_) {
        const Box& ba = box_[a];
        const std::uint32_t own = cell_of_[a];
        // Own cell: the bodies after a in its ascending run are exactly those with a greater id.
        for (std::uint32_t s = slot_of_[a] + 1, e = cell_start_[own] + cell_count_[own]; s < e; ++s) {
            const BodyId b = cell_items_[s];
            if (overlap(ba, box_[b])) out.push_back(BodyPair{a, b});
        }
        // Which neighbours a's box can reach at all: a body in the next cell up an axis has its
        // min corner at or above that cell's lower edge (clamping only ever moves bodies down
        // into cell 0 or up into the last cell, never into a next cell), and a body in the cell
        // below has its max corner under this cell's lower edge plus the widest gridded box.
        // A neighbour out of reach holds no pair, so skipping it leaves the output as it was.
        unsigned reach = 0;
        for (int k = 0; k < 3; ++k) {
            const std::int64_t i = coord(a, k) - 1;  // interior index
            const i128 lower = static_cast<i128>(origin_[k] + i) << cell_shift_;
            if (static_cast<i128>(ba.hi[k]) >= lower + (i128{1} << cell_shift_)) reach |= 1u << k;
            if (static_cast<i128>(ba.lo[k]) < lower + widest_) reach |= 8u << k;
        }
        for (int f = 0; f < 13; ++f) {
            if ((forward_need_[f] & ~reach) != 0) continue;
            const auto c = static_cast<std::size_t>(static_cast<std::int64_t>(own) + forward_offset_[f]);
            const std::uint32_t n = cell_count_[c];
            if (n == 0) continue;
            for (std::uint32_t s = cell_start_[c], e = s + n; s < e; ++s) {
                const BodyId b = cell_items_[s];
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
