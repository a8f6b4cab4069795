#include "sim/broadphase.h"

#include <algorithm>
#include <bit>
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
    // Coarsen until the grid has at most ~64 cells per body (memory), and the padded linear
    // cell index fits the 32 bits it has in a sort key.
    // In 128 bits: bounds spanning most of the int64 range at a cell edge of 1 or 2 raw units
    // have 2^63 or more cells along an axis (more than int64 holds), and three such counts
    // multiplied in 64 bits can wrap to a small number. Past 2^32 cells an axis is too many
    // anyway; below that the products fit (2^96).
    const std::uint64_t max_cells = std::max<std::uint64_t>(4096, 64 * gridded_.size());
    for (;;) {
        i128 cells = 1, padded = 1, dims[3];
        for (int k = 0; k < 3; ++k)
            dims[k] = static_cast<i128>(bounds.hi[k] >> cell_shift_) - (bounds.lo[k] >> cell_shift_) + 1;
        const bool countable = std::max({dims[0], dims[1], dims[2]}) <= UINT32_MAX;
        if (countable)
            for (int k = 0; k < 3; ++k) {
                cells *= dims[k];
                padded *= dims[k] + 2;
            }
        if ((countable && cells <= max_cells && padded <= UINT32_MAX) || cell_shift_ >= 62) {
            for (int k = 0; k < 3; ++k) {  // at cell_shift_ 62 every axis has at most 4 cells
                origin_[k] = bounds.lo[k] >> cell_shift_;
                dims_[k] = static_cast<std::int64_t>(dims[k]);
                last_[k] = bounds.hi[k] >> cell_shift_;
            }
            break;
        }
        ++cell_shift_;
    }
    const std::int64_t px = dims_[0] + 2, py = dims_[1] + 2, pz = dims_[2] + 2;  // with the border
    stride_y_ = px;
    stride_z_ = px * py;
    // Widest fattened box of a gridded body on any axis (hi - lo, as make_box builds it).
    widest_ = 0;
    for (BodyId id : gridded_) {
        const Box b = make_box(Vec3{}, extent[id], margin.raw);
        for (int k = 0; k < 3; ++k) widest_ = std::max(widest_, static_cast<i128>(b.hi[k]) - b.lo[k]);
    }
    down_reach_ = widest_ - 1;
    cell_.assign(static_cast<std::size_t>(px * py * pz), kEmptyCell);
    key_bits_ = 0;
    while ((std::uint64_t{1} << key_bits_) < cell_.size()) ++key_bits_;
    occupied_.clear();
}

void Broadphase::find_pairs(const std::vector<Vec3>& pos, const std::vector<Vec3>& extent, std::vector<BodyPair>& out,
                            const ParallelTasks& tasks) {
    out.clear();
    if (!statics_ready_) {  // statics never move: their boxes are computed once
        static_box_.clear();
        for (BodyId id : static_) static_box_.push_back(box_[id] = make_box(pos[id], extent[id], 0));
        // Grid: per axis and cell coordinate, the static bodies (bit = index in static_) that a
        // gridded box whose min corner has that coordinate can overlap. A box's min corner lies
        // in [static lo - widest_, static hi], and clamped floor division keeps that order, so
        // its coordinate lies between theirs: a necessary condition, never a lost pair.
        for (int k = 0; k < 3; ++k) static_mask_[k].assign(static_cast<std::size_t>(dims_[k] + 2), 0);
        if (kind_ == BroadphaseKind::Grid && static_.size() <= 64)
            for (std::size_t i = 0; i < static_.size(); ++i)
                for (int k = 0; k < 3; ++k) {
                    Box lowest{}, highest{};  // min corners at the two ends of the reach
                    lowest.lo[k] = sat(static_cast<i128>(static_box_[i].lo[k]) - widest_);
                    highest.lo[k] = static_box_[i].hi[k];
                    for (std::int64_t c = coord(lowest, k); c <= coord(highest, k); ++c)
                        static_mask_[k][static_cast<std::size_t>(c)] |= std::uint64_t{1} << i;
                }
        statics_ready_ = true;
    }
    bool keys_ready = false;
    if (!tasks.parallel() && kind_ == BroadphaseKind::Grid) {
        // Each gridded body's sort key with its box, while the box is in the first-level
        // cache: one pass over box_ fewer (at 10,000 bodies 480 KB, more than the L2 keeps
        // across the step). gridded_ is an ascending subsequence of dynamic_.
        keys_.resize(gridded_.size());
        std::size_t g = 0;
        for (BodyId id : dynamic_) {
            box_[id] = make_box(pos[id], extent[id], margin_.raw);
            if (g < gridded_.size() && gridded_[g] == id) keys_[g++] = key(id);
        }
        keys_ready = true;
    } else if (!tasks.parallel()) {  // the plain loop (a lambda's reloads cost the paper scene ~2 %)
        for (BodyId id : dynamic_) box_[id] = make_box(pos[id], extent[id], margin_.raw);
    } else {
        tasks.for_ranges(dynamic_.size(), kGrain, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i)
                box_[dynamic_[i]] = make_box(pos[dynamic_[i]], extent[dynamic_[i]], margin_.raw);
        });
    }
    if (kind_ == BroadphaseKind::Grid)
        grid(out, tasks, keys_ready);
    else
        sweep_and_prune(out);
    oversize_and_statics(out, tasks);
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

void Broadphase::grid(std::vector<BodyPair>& out, const ParallelTasks& tasks, bool keys_ready) {
    for (std::uint32_t c : occupied_) cell_[c] = kEmptyCell;
    occupied_.clear();

    const std::size_t n = gridded_.size();
    keys_.resize(n);
    keys_tmp_.resize(n);
    sorted_id_.resize(n);
    sorted_box_.resize(n);
    if (const std::size_t sort_pieces = tasks.piece_count(n, kGrain); sort_pieces > 1) {
        sort_and_layout(sort_pieces, tasks);
    } else {
        // Counting (radix) sort of the gridded bodies by linear cell index, kDigit bits a pass.
        // Keys start in ascending id order and every pass is stable, so each cell lists its
        // bodies in ascending id order: the layout is a pure function of the positions.
        if (!keys_ready)
            for (std::size_t i = 0; i < n; ++i) keys_[i] = key(gridded_[i]);
        for (int shift = 0; shift < key_bits_; shift += kDigit) {
            std::uint32_t histogram[kBuckets + 1] = {};
            for (std::uint64_t key : keys_) ++histogram[digit(key, shift) + 1];
            for (std::uint32_t d = 1; d <= kBuckets; ++d) histogram[d] += histogram[d - 1];
            for (std::uint64_t key : keys_) keys_tmp_[histogram[digit(key, shift)]++] = key;
            keys_.swap(keys_tmp_);
        }

        // Slots in sorted order; one run per occupied cell, the cells ascending.
        for (std::size_t s = 0; s < n; ++s) {
            const auto id = static_cast<BodyId>(keys_[s]);
            const auto c = static_cast<std::uint32_t>(keys_[s] >> 32);
            sorted_id_[s] = id;
            sorted_box_[s] = box_[id];
            Cell& cell = cell_[c];
            if (cell.end == 0) {
                cell.start = static_cast<std::uint32_t>(s);
                occupied_.push_back(c);
            }
            cell.end = static_cast<std::uint32_t>(s + 1);
        }
    }

    // Walk cell by cell, in ascending linear index (per range of occupied cells when parallel,
    // each range into its own scratch). The canonical order (docs/determinism.md) is the
    // walk's own: the cells ascending, in each cell its bodies by ascending id, each body's
    // pairs as its walk finds them, its static pairs last. Ranges are runs of consecutive
    // occupied cells, so their lists concatenated in range order are the one-range walk's
    // list, whatever the cut.
    const std::size_t pieces = tasks.piece_count(occupied_.size(), kCellGrain);
    if (scratch_.size() < pieces) {
        scratch_.resize(pieces);
        found_.resize(pieces);
    }
    if (pieces <= 1) {
        found_[0] = walk(0, occupied_.size(), 0);
    } else {
        tasks.run(pieces, [&](std::size_t k) {
            const std::size_t n_occ = occupied_.size();
            found_[k] = walk(n_occ * k / pieces, n_occ * (k + 1) / pieces, static_cast<std::uint32_t>(k));
        });
    }
    for (std::size_t k = 0; k < pieces; ++k) out.insert(out.end(), scratch_[k].begin(), scratch_[k].begin() + found_[k]);
}

void Broadphase::sort_and_layout(std::size_t pieces, const ParallelTasks& tasks) {
    // The keys are distinct (the id is in them), so the sorted order is unique: any correct
    // sort gives the sequential one's. This one is the same LSD radix sort, each pass cut into
    // ranges of the keys: a histogram per (range, digit), offsets by digit then range (stable),
    // each range scattering its keys. The layout then writes each slot's id and box, and a
    // cell's start (end) at the slot whose key differs from the previous (next) slot's.
    const std::size_t n = gridded_.size();
    const auto first = [&](std::size_t k) { return n * k / pieces; };
    histograms_.resize(pieces * kBuckets);
    const auto count = [&](std::size_t k, int shift) {
        std::uint32_t* h = &histograms_[k * kBuckets];
        std::fill(h, h + kBuckets, 0u);
        for (std::size_t i = first(k), e = first(k + 1); i < e; ++i) ++h[digit(keys_[i], shift)];
    };
    tasks.run(pieces, [&](std::size_t k) {
        for (std::size_t i = first(k), e = first(k + 1); i < e; ++i) keys_[i] = key(gridded_[i]);
        if (key_bits_ > 0) count(k, 0);
    });
    for (int shift = 0; shift < key_bits_; shift += kDigit) {
        if (shift > 0) tasks.run(pieces, [&](std::size_t k) { count(k, shift); });
        std::uint32_t total = 0;
        for (std::uint32_t d = 0; d < kBuckets; ++d)
            for (std::size_t k = 0; k < pieces; ++k) {
                const std::uint32_t c = histograms_[k * kBuckets + d];
                histograms_[k * kBuckets + d] = total;
                total += c;
            }
        tasks.run(pieces, [&](std::size_t k) {
            std::uint32_t* h = &histograms_[k * kBuckets];
            for (std::size_t i = first(k), e = first(k + 1); i < e; ++i)
                keys_tmp_[h[digit(keys_[i], shift)]++] = keys_[i];
        });
        keys_.swap(keys_tmp_);
    }

    if (occupied_parts_.size() < pieces) occupied_parts_.resize(pieces);
    tasks.run(pieces, [&](std::size_t k) {
        std::vector<std::uint32_t>& occupied = occupied_parts_[k];
        occupied.clear();
        for (std::size_t s = first(k), e = first(k + 1); s < e; ++s) {
            const auto id = static_cast<BodyId>(keys_[s]);
            const auto c = static_cast<std::uint32_t>(keys_[s] >> 32);
            sorted_id_[s] = id;
            sorted_box_[s] = box_[id];
            if (s == 0 || static_cast<std::uint32_t>(keys_[s - 1] >> 32) != c) {
                cell_[c].start = static_cast<std::uint32_t>(s);
                occupied.push_back(c);
            }
            if (s + 1 == n || static_cast<std::uint32_t>(keys_[s + 1] >> 32) != c)
                cell_[c].end = static_cast<std::uint32_t>(s + 1);
        }
    });
    for (std::size_t k = 0; k < pieces; ++k)
        occupied_.insert(occupied_.end(), occupied_parts_[k].begin(), occupied_parts_[k].end());
}

std::uint32_t Broadphase::walk(std::size_t first, std::size_t last, std::uint32_t piece) {
    std::vector<BodyPair>& scratch = scratch_[piece];
    std::uint32_t used = 0;  // pairs in scratch (its size only grows: no clearing per body)
    for (std::size_t oi = first; oi < last; ++oi) {
        const std::uint32_t own = occupied_[oi];
        const Cell here = cell_[own];
        // Which neighbours a box in this cell can reach at all: a body in the next cell up an
        // axis has its min corner at or above that cell's lower edge (clamping only ever moves
        // bodies down into cell 0 or up into the last cell, never into a next cell), and a body
        // in the cell below has its max corner under this cell's lower edge plus the widest
        // gridded box. A neighbour out of reach holds no pair, so skipping it changes nothing.
        // Only y and z need it: the runs below span x - 1 .. x + 1 whole. The cell's coordinates
        // are any of its bodies' (the first one's), with no division.
        // Saturating up_edge to int64 can only add reach (extra tests), never lose a pair;
        // down_edge is the inclusive bound so that saturating it is exact.
        std::int64_t up_edge[3] = {}, down_edge[3] = {};
        for (int k = 1; k < 3; ++k) {
            const std::int64_t interior = coord(sorted_box_[here.start], k) - 1;
            const i128 lower = static_cast<i128>(origin_[k] + interior) << cell_shift_;
            up_edge[k] = sat(lower + (i128{1} << cell_shift_));
            // A box below has its max corner at most lower - 1 + widest_: a's min corner must be
            // at most that. Saturated as `lo < sat(lower + widest_)` this lost the pair of a box
            // whose min corner is INT64_MAX in the top cell (lower + widest_ past the limit);
            // `lo <= sat(lower + down_reach_)` is the same test below the limit and exact at it
            // (for an int64 lo, lo <= sat(v) iff lo <= v, but for v = INT64_MIN - 1: one extra).
            down_edge[k] = sat(lower + down_reach_);
        }
        // The 13 forward neighbours are the next cell along x plus four rows of three cells
        // (x - 1, x, x + 1). Cells are sorted by linear index, so each row's bodies are one
        // contiguous run of slots, in the (z, y, x) order of its cells; a run is scanned whole
        // and the overlap test decides along x.
        auto run = [&](std::int64_t middle) {
            const Cell* c = &cell_[static_cast<std::size_t>(middle - 1)];
            return Cell{std::min({c[0].start, c[1].start, c[2].start}), std::max({c[0].end, c[1].end, c[2].end})};
        };
        const auto o = static_cast<std::int64_t>(own);
        const std::uint32_t row_end = std::max(here.end, cell_[static_cast<std::size_t>(o + 1)].end);
        // Rows (dy, dz) = (1, 0), (-1, 1), (0, 1), (1, 1), and the reach each needs.
        const Cell rows[4] = {run(o + stride_y_), run(o - stride_y_ + stride_z_), run(o + stride_z_),
                              run(o + stride_y_ + stride_z_)};
        constexpr unsigned kRowNeed[4] = {2u, 16u | 4u, 4u, 2u | 4u};

        // The static bodies a box of this cell can touch at all (static_mask_): most cells
        // touch none, a floor cell one, so each body tests only those; the pairs are the same.
        std::uint64_t near = 0;
        std::uint32_t n_near = 0;
        if (!static_.empty()) {
            const Box& first_box = sorted_box_[here.start];
            near = static_.size() > 64 ? ~std::uint64_t{0}
                                       : static_mask_[0][static_cast<std::size_t>(coord(first_box, 0))] &
                                             static_mask_[1][static_cast<std::size_t>(coord(first_box, 1))] &
                                             static_mask_[2][static_cast<std::size_t>(coord(first_box, 2))];
            n_near = static_.size() > 64 ? static_cast<std::uint32_t>(static_.size())
                                         : static_cast<std::uint32_t>(std::popcount(near));
        }

        for (std::uint32_t s = here.start; s < here.end; ++s) {
            const BodyId a = sorted_id_[s];
            const Box ba = sorted_box_[s];
            // Room for every candidate, so the scans store unconditionally and keep a pair only
            // when the boxes overlap: no branch on the test (a coin toss in a pile).
            std::uint32_t room = row_end - s - 1 + n_near;
            for (const Cell& row : rows) room += row.end > row.start ? row.end - row.start : 0;
            if (scratch.size() < std::size_t{used} + room) scratch.resize(2 * (std::size_t{used} + room));
            BodyPair* w = scratch.data();
            auto scan = [&](std::uint32_t t, std::uint32_t te) {
                for (; t < te; ++t) {
                    const BodyId b = sorted_id_[t];
                    w[used] = BodyPair{std::min(a, b), std::max(a, b)};
                    used += overlap_bits(ba, sorted_box_[t]);
                }
            };
            // Own cell first: the bodies after a in its ascending run are exactly those with a
            // greater id; then the next cell along x, which follows it in slot order.
            scan(s + 1, row_end);
            unsigned reach = 0;
            for (int k = 1; k < 3; ++k) {
                reach |= static_cast<unsigned>(ba.hi[k] >= up_edge[k]) << k;
                reach |= static_cast<unsigned>(ba.lo[k] <= down_edge[k]) << (3 + k);
            }
            // A row out of reach scans nothing ([start, start)); no branch on the reach, which
            // is data-dependent when the cell edge has slack over the boxes.
            for (int r = 0; r < 4; ++r) scan(rows[r].start, (kRowNeed[r] & ~reach) == 0 ? rows[r].end : rows[r].start);
            // Then a's static pairs, the static bodies ascending: a's block holds every pair the
            // solver will sweep for a except those of bodies before it, so a sweep reads a's
            // data once per block instead of again in a static-major tail (docs/determinism.md,
            // "Canonical pair order").
            if (n_near > 0) used = static_tests(a, ba, near, w, used);
        }
    }
    return used;
}

std::uint32_t Broadphase::static_tests(BodyId a, const Box& ba, std::uint64_t near, BodyPair* w,
                                       std::uint32_t used) const {
    if (static_.size() > 64) {  // no masks: every static body
        for (std::size_t k = 0; k < static_.size(); ++k) {
            w[used] = BodyPair{std::min(a, static_[k]), std::max(a, static_[k])};
            used += overlap_bits(ba, static_box_[k]);
        }
        return used;
    }
    for (; near != 0; near &= near - 1) {  // ascending bits: the static bodies ascending
        const auto k = static_cast<std::size_t>(std::countr_zero(near));
        w[used] = BodyPair{std::min(a, static_[k]), std::max(a, static_[k])};
        used += overlap_bits(ba, static_box_[k]);
    }
    return used;
}

void Broadphase::oversize_and_statics(std::vector<BodyPair>& out, const ParallelTasks& tasks) {
    if (kind_ == BroadphaseKind::Grid) {
        // Oversize bodies against every dynamic body (each oversize-oversize pair once).
        for (BodyId o : oversize_)
            for (BodyId d : dynamic_) {
                if (d == o) continue;
                const bool other_oversize = std::binary_search(oversize_.begin(), oversize_.end(), d);
                if (other_oversize && d < o) continue;
                if (overlap(box_[o], box_[d])) out.push_back(o < d ? BodyPair{o, d} : BodyPair{d, o});
            }
        // The gridded bodies' static pairs came with their walk blocks; the oversize bodies'
        // follow here, each oversize body's (ascending id) against the static bodies ascending.
        for (BodyId o : oversize_)
            for (std::size_t k = 0; k < static_.size(); ++k)
                if (overlap(static_box_[k], box_[o]))
                    out.push_back(o < static_[k] ? BodyPair{o, static_[k]} : BodyPair{static_[k], o});
        return;
    }
    // Sweep and prune: static bodies against every dynamic body, static-major: per range of the
    // (static, dynamic) index when parallel, each range into its own list, the lists
    // concatenated in range order.
    const std::size_t nd = dynamic_.size(), n = static_.size() * nd;
    const std::size_t pieces = tasks.piece_count(n, kStaticGrain);
    const auto tests = [&](std::size_t begin, std::size_t end, std::vector<BodyPair>& list) {
        // (static, dynamic) = (i / nd, i % nd), divided once per range; the inner loop is the
        // plain one's, over [di, stop) (a second bound in it cost the tests ~20 %).
        for (std::size_t si = begin / nd, di = begin - si * nd, i = begin; i < end; ++si, di = 0) {
            const BodyId s = static_[si];
            const Box& bs = box_[s];
            const std::size_t stop = std::min(nd, di + (end - i));
            i += stop - di;
            for (; di < stop; ++di) {
                const BodyId d = dynamic_[di];
                if (overlap(bs, box_[d])) list.push_back(s < d ? BodyPair{s, d} : BodyPair{d, s});
            }
        }
    };
    if (pieces <= 1 && (nd <= kStaticBlock || static_.size() < 2)) {
        // The plain loops: the paper scene's step spends a tenth of its time here.
        for (BodyId s : static_) {
            const Box& bs = box_[s];
            for (BodyId d : dynamic_)
                if (overlap(bs, box_[d])) out.push_back(s < d ? BodyPair{s, d} : BodyPair{d, s});
        }
        return;
    }
    if (pieces <= 1) {
        // The same tests a block of dynamic bodies at a time, every static body against the
        // block while its boxes are in the first-level cache (one pass over box_ instead of one
        // per static body), each static body's pairs into its own list, the lists concatenated
        // in static order: the plain loops' pairs in their order.
        if (static_pairs_.size() < static_.size()) static_pairs_.resize(static_.size());
        for (std::size_t si = 0; si < static_.size(); ++si) static_pairs_[si].clear();
        for (std::size_t d0 = 0; d0 < nd; d0 += kStaticBlock) {
            const std::size_t d1 = std::min(nd, d0 + kStaticBlock);
            for (std::size_t si = 0; si < static_.size(); ++si) {
                const BodyId s = static_[si];
                const Box& bs = box_[s];
                std::vector<BodyPair>& list = static_pairs_[si];
                for (std::size_t di = d0; di < d1; ++di) {
                    const BodyId d = dynamic_[di];
                    if (overlap(bs, box_[d])) list.push_back(s < d ? BodyPair{s, d} : BodyPair{d, s});
                }
            }
        }
        for (std::size_t si = 0; si < static_.size(); ++si)
            out.insert(out.end(), static_pairs_[si].begin(), static_pairs_[si].end());
        return;
    }
    if (static_pairs_.size() < pieces) static_pairs_.resize(pieces);
    tasks.run(pieces, [&](std::size_t k) {
        static_pairs_[k].clear();
        tests(n * k / pieces, n * (k + 1) / pieces, static_pairs_[k]);
    });
    for (std::size_t k = 0; k < pieces; ++k) out.insert(out.end(), static_pairs_[k].begin(), static_pairs_[k].end());
}

}  // namespace lockroll::sim
