// The grid broadphase against a brute-force reference: it must find exactly the pairs whose
// fattened boxes overlap (no miss, no duplicate, no static-static pair), wherever the bodies have
// moved since configure() (also far outside the grid's bounds, where they are clamped into the
// border cells), and its output must be a pure function of the current positions.
#include "sim/broadphase.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "sim/parallel_tasks.h"
#include "sim/rng.h"

namespace lockroll::sim {
namespace {

Fixed random_in(SplitMix64& rng, std::int64_t lo_mm, std::int64_t hi_mm) {
    const auto mm = lo_mm + static_cast<std::int64_t>(rng.below(static_cast<std::uint64_t>(hi_mm - lo_mm)));
    return Fixed::from_int(mm) / Fixed::from_int(1000);
}

struct Scene {
    std::vector<BodyId> dynamic, statics;
    std::vector<Vec3> pos, extent;
};

// n dynamic cubes of half size 0.15 m in a 6 x 2 x 6 m box (dense: many neighbours per cell),
// three of them larger (the oversize list), plus a floor and a wall.
Scene make_scene(std::uint64_t seed, int n) {
    SplitMix64 rng(seed);
    Scene s;
    for (int i = 0; i < n; ++i) {
        s.dynamic.push_back(static_cast<BodyId>(s.pos.size()));
        s.pos.push_back({random_in(rng, -3000, 3000), random_in(rng, 0, 2000), random_in(rng, -3000, 3000)});
        const Fixed h = i % 700 == 5 ? Fixed::from_int(1) : Fixed::from_int(15) / Fixed::from_int(100);
        s.extent.push_back({h, h, h});
    }
    for (int k = 0; k < 2; ++k) {
        s.statics.push_back(static_cast<BodyId>(s.pos.size()));
        s.pos.push_back(k == 0 ? Vec3{Fixed::zero(), Fixed::from_int(-1), Fixed::zero()}
                               : Vec3{Fixed::from_int(4), Fixed::from_int(1), Fixed::zero()});
        s.extent.push_back(k == 0 ? Vec3{Fixed::from_int(10), Fixed::one(), Fixed::from_int(10)}
                                  : Vec3{Fixed::one(), Fixed::from_int(2), Fixed::from_int(10)});
    }
    return s;
}

std::vector<std::pair<BodyId, BodyId>> brute_force(const Scene& s, Fixed margin) {
    auto overlap = [&](BodyId a, BodyId b, bool a_static, bool b_static) {
        for (int k = 0; k < 3; ++k) {
            auto get = [&](const Vec3& v) { return k == 0 ? v.x : k == 1 ? v.y : v.z; };
            const Fixed ra = get(s.extent[a]) + (a_static ? Fixed::zero() : margin);
            const Fixed rb = get(s.extent[b]) + (b_static ? Fixed::zero() : margin);
            const Fixed d = get(s.pos[a]) - get(s.pos[b]);
            if ((d < Fixed::zero() ? -d : d) > ra + rb) return false;
        }
        return true;
    };
    std::vector<std::pair<BodyId, BodyId>> out;
    for (std::size_t i = 0; i < s.dynamic.size(); ++i) {
        for (std::size_t j = i + 1; j < s.dynamic.size(); ++j)
            if (overlap(s.dynamic[i], s.dynamic[j], false, false)) out.emplace_back(s.dynamic[i], s.dynamic[j]);
        for (BodyId st : s.statics)
            if (overlap(s.dynamic[i], st, false, true)) out.emplace_back(std::min(s.dynamic[i], st), std::max(s.dynamic[i], st));
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<std::pair<BodyId, BodyId>> sorted_pairs(const std::vector<BodyPair>& pairs) {
    std::vector<std::pair<BodyId, BodyId>> out;
    for (const BodyPair& p : pairs) {
        EXPECT_LT(p.a, p.b);
        out.emplace_back(p.a, p.b);
    }
    std::sort(out.begin(), out.end());
    return out;
}

const Fixed kMargin = Fixed::from_int(2) / Fixed::from_int(100);

// A grid broadphase configured for s, and its pairs at s's positions.
std::vector<BodyPair> grid_pairs(const Scene& s, Broadphase& bp) {
    bp.configure(BroadphaseKind::Grid, s.dynamic, s.statics, s.pos, s.extent, kMargin);
    std::vector<BodyPair> pairs;
    bp.find_pairs(s.pos, s.extent, pairs);
    return pairs;
}

TEST(Broadphase, GridFindsExactlyTheOverlappingPairs) {
    Scene s = make_scene(19, 3000);
    Broadphase bp;
    std::vector<BodyPair> pairs = grid_pairs(s, bp);
    const auto expected = brute_force(s, kMargin);
    ASSERT_GT(expected.size(), 1000u) << "the scene must be dense enough to test neighbours";
    EXPECT_EQ(sorted_pairs(pairs), expected);

    // Move every body, a tenth of them far outside the bounds the grid was built for.
    SplitMix64 rng(7);
    for (std::size_t i = 0; i < s.dynamic.size(); ++i) {
        Vec3& p = s.pos[s.dynamic[i]];
        if (i % 10 == 0)
            p = {random_in(rng, 40000, 40600), random_in(rng, -30000, -29800), random_in(rng, -200, 200)};
        else
            p = {p.x + random_in(rng, -300, 300), p.y + random_in(rng, -300, 300), p.z + random_in(rng, -300, 300)};
    }
    bp.find_pairs(s.pos, s.extent, pairs);
    EXPECT_EQ(sorted_pairs(pairs), brute_force(s, kMargin));
}

// Scattered small static boxes: the walk tests a body only against the static bodies its
// cell's masks reach (at most 64), or every static body beyond 64; both must lose no pair.
TEST(Broadphase, GridStaticMasksLoseNoPair) {
    for (const int extra : {20, 70}) {
        Scene s = make_scene(static_cast<std::uint64_t>(41 + extra), 2000);
        SplitMix64 rng(static_cast<std::uint64_t>(extra));
        for (int i = 0; i < extra; ++i) {
            s.statics.push_back(static_cast<BodyId>(s.pos.size()));
            s.pos.push_back({random_in(rng, -3500, 3500), random_in(rng, -500, 2500), random_in(rng, -3500, 3500)});
            s.extent.push_back({random_in(rng, 10, 600), random_in(rng, 10, 600), random_in(rng, 10, 600)});
        }
        Broadphase bp;
        const auto expected = brute_force(s, kMargin);
        ASSERT_GT(expected.size(), 1000u);
        EXPECT_EQ(sorted_pairs(grid_pairs(s, bp)), expected) << extra << " extra static bodies";
    }
}

TEST(Broadphase, GridOutputDependsOnlyOnCurrentPositions) {
    // One broadphase that has seen other positions first, one fresh: identical output, order
    // included (the order is part of the simulation: docs/determinism.md).
    Scene s = make_scene(23, 2000);
    Scene moved = s;
    SplitMix64 rng(3);
    for (BodyId id : moved.dynamic) moved.pos[id].x = moved.pos[id].x + random_in(rng, -500, 500);
    Broadphase seasoned, fresh;
    seasoned.configure(BroadphaseKind::Grid, s.dynamic, s.statics, s.pos, s.extent, kMargin);
    fresh.configure(BroadphaseKind::Grid, s.dynamic, s.statics, s.pos, s.extent, kMargin);
    std::vector<BodyPair> a, b;
    seasoned.find_pairs(s.pos, s.extent, a);
    seasoned.find_pairs(moved.pos, moved.extent, a);
    fresh.find_pairs(moved.pos, moved.extent, b);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_FALSE(a.empty());
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].a, b[i].a) << "pair " << i;
        EXPECT_EQ(a[i].b, b[i].b) << "pair " << i;
    }
}

TEST(Broadphase, GridPairsComeInCellOrder) {
    // The canonical order (docs/determinism.md): the pairs of gridded bodies in walk order, a
    // pair found by the body with the lower (cell, id) key, the finders by ascending key, a
    // cell's key its (z, y, x) coordinates. Cubes of half size 0.15 m with a 0.02 m margin
    // get 0.5 m cells (2^31 raw units: a coordinate is the fattened min corner >> 31), and the
    // make_scene bounds need no coarsening.
    const Scene s = make_scene(29, 3000);
    Broadphase bp;
    const std::vector<BodyPair> pairs = grid_pairs(s, bp);
    const Fixed small = Fixed::from_int(15) / Fixed::from_int(100);
    auto gridded = [&](BodyId id) {
        return id < s.extent.size() - s.statics.size() && s.extent[id].x == small;
    };
    auto key = [&](BodyId id) {
        auto cell = [&](Fixed c) { return (c - small - kMargin).raw >> 31; };
        const Vec3& p = s.pos[id];
        return std::array<std::int64_t, 4>{cell(p.z), cell(p.y), cell(p.x), id};
    };
    std::array<std::int64_t, 4> last{INT64_MIN, INT64_MIN, INT64_MIN, INT64_MIN};
    std::size_t checked = 0;
    for (const BodyPair& p : pairs) {
        if (!gridded(p.a) || !gridded(p.b)) continue;
        const auto finder = std::min(key(p.a), key(p.b));
        EXPECT_LE(last, finder) << "pair (" << p.a << ", " << p.b << ") comes after one found in a later cell";
        if (last > finder) break;
        last = finder;
        ++checked;
    }
    EXPECT_GT(checked, 1000u);
}

// A gridded body's static pairs come right after its own block of walk pairs, the static
// bodies ascending (docs/determinism.md, "Canonical pair order"), so the solver's sweep meets
// all of a body's pairs together; the oversize bodies' pairs come last, their static pairs
// after their dynamic ones, by (oversize id, static id). The sequential and the parallel walks
// both (the parallel ones: GridParallelMatchesSequentialAtAnyCut).
TEST(Broadphase, StaticPairsComeWithTheirBodysBlock) {
    const Scene s = make_scene(37, 3000);  // two static bodies, a few oversize ones
    Broadphase bp;
    const std::vector<BodyPair> pairs = grid_pairs(s, bp);
    const Fixed small = Fixed::from_int(15) / Fixed::from_int(100);
    const BodyId first_static = s.statics.front();
    auto is_static = [&](BodyId id) { return id >= first_static; };
    auto gridded = [&](BodyId id) { return !is_static(id) && s.extent[id].x == small; };
    auto key = [&](BodyId id) {  // as in GridPairsComeInCellOrder
        auto cell = [&](Fixed c) { return (c - small - kMargin).raw >> 31; };
        const Vec3& p = s.pos[id];
        return std::array<std::int64_t, 4>{cell(p.z), cell(p.y), cell(p.x), id};
    };
    // Rank of a gridded body's pair: its finder's key, then 0 for a walk pair or 1 + the
    // static id for a static pair. Ranks must never go down; the oversize tail is ranked apart.
    using Rank = std::pair<std::array<std::int64_t, 4>, std::int64_t>;
    Rank last{{INT64_MIN, INT64_MIN, INT64_MIN, INT64_MIN}, INT64_MIN};
    std::pair<std::int64_t, std::int64_t> last_tail{INT64_MIN, INT64_MIN};
    bool in_tail = false, tail_statics = false;
    std::size_t static_pairs = 0;
    for (const BodyPair& p : pairs) {
        auto oversize = [&](BodyId id) { return !is_static(id) && !gridded(id); };
        const bool tail = oversize(p.a) || oversize(p.b);  // an oversize body's pair
        if (!tail) {
            ASSERT_FALSE(in_tail) << "pair (" << p.a << ", " << p.b << ") after the oversize pairs";
            Rank rank = is_static(p.b) ? Rank{key(p.a), 1 + std::int64_t{p.b}} : Rank{std::min(key(p.a), key(p.b)), 0};
            static_pairs += is_static(p.b) ? 1 : 0;
            ASSERT_LE(last, rank) << "pair (" << p.a << ", " << p.b << ") out of its body's block";
            last = rank;
            continue;
        }
        in_tail = true;
        if (!is_static(p.b)) {
            ASSERT_FALSE(tail_statics) << "oversize pair (" << p.a << ", " << p.b << ") after the oversize static pairs";
            continue;
        }
        tail_statics = true;
        const std::pair<std::int64_t, std::int64_t> t{p.a, p.b};
        ASSERT_LT(last_tail, t);
        last_tail = t;
    }
    EXPECT_GT(static_pairs, 300u) << "many blocks must hold static pairs";
    EXPECT_TRUE(tail_statics) << "an oversize body must touch a static body";
}

// The parallel step's grid (the sort, layout, walk and static tests cut into ranges) returns
// the sequential pairs in the sequential order, at any cut: several task counts, body counts
// on both sides of the ranges' grain, tasks run last first, and a broadphase that stepped
// sequentially before (the layout's cells are reused).
TEST(Broadphase, GridParallelMatchesSequentialAtAnyCut) {
    const TaskRunner backwards = [](std::size_t count, const std::function<void(std::size_t)>& task) {
        for (std::size_t i = count; i-- > 0;) task(i);
    };
    for (const int n : {1500, 2100, 5000}) {
        Scene s = make_scene(static_cast<std::uint64_t>(31 + n), n);
        Broadphase seq;
        const std::vector<BodyPair> expected = grid_pairs(s, seq);
        ASSERT_FALSE(expected.empty());
        for (const int chunks : {2, 3, 5, 8}) {
            const ParallelTasks tasks(chunks, backwards);
            Broadphase par;
            par.configure(BroadphaseKind::Grid, s.dynamic, s.statics, s.pos, s.extent, kMargin);
            std::vector<BodyPair> pairs;
            par.find_pairs(s.pos, s.extent, pairs);  // sequential first
            par.find_pairs(s.pos, s.extent, pairs, tasks);
            ASSERT_EQ(pairs.size(), expected.size()) << n << " bodies, " << chunks << " tasks";
            for (std::size_t i = 0; i < pairs.size(); ++i) {
                ASSERT_EQ(pairs[i].a, expected[i].a) << n << " bodies, " << chunks << " tasks, pair " << i;
                ASSERT_EQ(pairs[i].b, expected[i].b) << n << " bodies, " << chunks << " tasks, pair " << i;
            }
        }
    }
}


// The sequential step computes each gridded body's sort key in its box loop, walking the
// gridded ids along the dynamic ones; the parallel step computes the keys apart. Oversize
// bodies (not gridded) first, last and in between by id must not shift a key to another body:
// the same pairs in the same order as the parallel path, and exactly the overlapping ones.
TEST(Broadphase, GridKeysInTheBoxLoopSkipOversizeBodies) {
    Scene s = make_scene(77, 2200);
    const Fixed big = Fixed::from_int(1);
    for (const BodyId id : {s.dynamic.front(), s.dynamic[1], s.dynamic[1100], s.dynamic.back()})
        s.extent[id] = {big, big, big};
    Broadphase seq;
    const std::vector<BodyPair> sequential = grid_pairs(s, seq);
    EXPECT_EQ(sorted_pairs(sequential), brute_force(s, kMargin));
    Broadphase par;
    par.configure(BroadphaseKind::Grid, s.dynamic, s.statics, s.pos, s.extent, kMargin);
    std::vector<BodyPair> parallel;
    par.find_pairs(s.pos, s.extent, parallel, ParallelTasks(3, [](std::size_t count, const std::function<void(std::size_t)>& task) {
                       for (std::size_t i = 0; i < count; ++i) task(i);
                   }));
    ASSERT_EQ(parallel.size(), sequential.size());
    for (std::size_t i = 0; i < parallel.size(); ++i) {
        ASSERT_EQ(parallel[i].a, sequential[i].a) << "pair " << i;
        ASSERT_EQ(parallel[i].b, sequential[i].b) << "pair " << i;
    }
}

// ---- The Q32.32 limits. ----
// Boxes there saturate to int64 (make_box), and so do the grid's cell edges; the reference is
// exact (128-bit) arithmetic on the unsaturated boxes, which saturation never changes the
// verdict of: a min corner below INT64_MIN only ever meets a max corner >= INT64_MIN, and a
// max corner above INT64_MAX only ever meets a min corner <= INT64_MAX.
using Pairs = std::vector<std::pair<BodyId, BodyId>>;

Pairs exact_pairs(const Scene& s, Fixed margin) {
    auto overlap = [&](BodyId a, BodyId b, bool b_static) {
        for (int k = 0; k < 3; ++k) {
            auto get = [&](const Vec3& v) { return static_cast<i128>(k == 0 ? v.x.raw : k == 1 ? v.y.raw : v.z.raw); };
            const i128 reach = get(s.extent[a]) + margin.raw + get(s.extent[b]) + (b_static ? 0 : margin.raw);
            const i128 d = get(s.pos[a]) - get(s.pos[b]);
            if ((d < 0 ? -d : d) > reach) return false;
        }
        return true;
    };
    Pairs out;
    for (std::size_t i = 0; i < s.dynamic.size(); ++i) {
        for (std::size_t j = i + 1; j < s.dynamic.size(); ++j)
            if (overlap(s.dynamic[i], s.dynamic[j], false)) out.emplace_back(s.dynamic[i], s.dynamic[j]);
        for (BodyId st : s.statics)
            if (overlap(s.dynamic[i], st, true))
                out.emplace_back(std::min(s.dynamic[i], st), std::max(s.dynamic[i], st));
    }
    std::sort(out.begin(), out.end());
    return out;
}

Pairs pairs_of(BroadphaseKind kind, const Scene& s, Fixed margin) {
    Broadphase bp;
    bp.configure(kind, s.dynamic, s.statics, s.pos, s.extent, margin);
    std::vector<BodyPair> pairs;
    bp.find_pairs(s.pos, s.extent, pairs);
    return sorted_pairs(pairs);
}

void set(Vec3& v, int k, std::int64_t raw) { (k == 0 ? v.x : k == 1 ? v.y : v.z) = Fixed::from_raw(raw); }

// Bodies around the corner of the grid at a limit: along each axis in `at_limit` the
// positions limit, limit -+ 1, E - 1, E, E + 1, 2E (inwards), along the others the cell
// corners around 0 (-E, -1, 0, 1, E, 2E); boxes of half size E (the cell edge is 2E, every
// box exactly as wide as a cell: the widest edge), each also flat (half size 0) along one axis,
// so its min corner can sit on the limit itself. margin 0 keeps it there; margin > 0 is the
// same boxes grown by the margin, the half sizes shrunk to match.
Scene limit_corner(bool high, unsigned at_limit, std::int64_t margin) {
    constexpr std::int64_t E = std::int64_t{1} << 31;  // half a metre
    const std::int64_t limit = high ? INT64_MAX : INT64_MIN, in = high ? -1 : 1;
    const std::int64_t along_limit[] = {0, 1, E - 1, E, E + 1, 2 * E};
    const std::int64_t along_rest[] = {-E, -1, 0, 1, E, 2 * E};
    Scene s;
    for (int shape = 0; shape < 4; ++shape)
        for (int i = 0; i < 6; ++i)
            for (int j = 0; j < 6; ++j)
                for (int l = 0; l < 6; ++l) {
                    const int idx[3] = {i, j, l};
                    Vec3 p{}, e{};
                    for (int k = 0; k < 3; ++k) {
                        set(p, k, at_limit >> k & 1 ? limit + in * along_limit[idx[k]] : along_rest[idx[k]]);
                        set(e, k, shape == k + 1 ? 0 : E - margin);
                    }
                    s.dynamic.push_back(static_cast<BodyId>(s.pos.size()));
                    s.pos.push_back(p);
                    s.extent.push_back(e);
                }
    // Static boxes on the limit corner (the walk's static masks): a point, a cell's size, three.
    for (const std::int64_t half : {std::int64_t{0}, E, 3 * E}) {
        Vec3 p{}, e{};
        for (int k = 0; k < 3; ++k) {
            set(p, k, at_limit >> k & 1 ? limit : 0);
            set(e, k, half);
        }
        s.statics.push_back(static_cast<BodyId>(s.pos.size()));
        s.pos.push_back(p);
        s.extent.push_back(e);
    }
    return s;
}

// The grid's reach into the row below along y (dy = -1, dz = +1) needs a's min corner under
// that row's cell edge plus the widest box. That edge saturated at INT64_MAX in the top cell,
// so a box whose min corner is INT64_MAX itself (on the limit, flat along y) skipped the row,
// and missed a box below it whose max corner saturates to INT64_MAX too. Every combination of
// limit, axis (and all three at once) and margin, grid and sweep and prune alike. The other
// edges pass on main and are pinned here: at INT64_MIN a cell's lower edge plus the widest box
// never saturates, a saturated up edge only adds reach, x has no reach test (the rows span
// x - 1 .. x + 1), the static masks' lowest reach saturates only where no min corner lies
// below it, and sweep and prune compares the saturated corners directly.
TEST(Broadphase, ExactAtThePositionLimits) {
    for (const bool high : {true, false})
        for (const unsigned at_limit : {1u, 2u, 4u, 7u})
            for (const std::int64_t margin : {std::int64_t{0}, std::int64_t{1} << 20}) {
                const Scene s = limit_corner(high, at_limit, margin);
                const Fixed m = Fixed::from_raw(margin);
                const Pairs expected = exact_pairs(s, m);
                ASSERT_GT(expected.size(), 1000u);
                EXPECT_EQ(pairs_of(BroadphaseKind::Grid, s, m), expected)
                    << (high ? "max" : "min") << " axes " << at_limit << " margin " << margin;
                EXPECT_EQ(pairs_of(BroadphaseKind::SweepAndPrune, s, m), expected)
                    << (high ? "max" : "min") << " axes " << at_limit << " margin " << margin;
            }
}

// The smallest case of the above: a (min corner INT64_MAX along y) and b, one cell down y and
// one up z, touching at y = INT64_MAX.
TEST(Broadphase, GridReachesTheRowBelowFromTheTopCell) {
    constexpr std::int64_t E = std::int64_t{1} << 31;
    Scene s;
    s.dynamic = {0, 1};
    const Fixed e = Fixed::from_raw(E);
    s.pos = {{Fixed::zero(), Fixed::max(), Fixed::zero()}, {Fixed::zero(), Fixed::from_raw(INT64_MAX - E), e}};
    s.extent = {{e, Fixed::zero(), e}, {e, e, e}};
    EXPECT_EQ(exact_pairs(s, Fixed::zero()), (Pairs{{0, 1}}));
    EXPECT_EQ(pairs_of(BroadphaseKind::Grid, s, Fixed::zero()), (Pairs{{0, 1}}));
}

// Bounds spanning the whole int64 range with the finest cells (half sizes of 0 or 1 raw unit,
// margin 0): the cell count per axis (up to 2^64) must not overflow int64 or wrap in the
// product that picks the cell size. It did at a cell edge of 2 raw units: x spanning
// INT64_MIN..INT64_MAX gave 2^63 cells (INT64_MIN as int64), and 2^63 x 2 x 2 cells wrapped to
// 0, so that grid was accepted and its keys indexed past the cell array. With a cell edge of
// 1 raw unit a body's cell coordinate (min corner minus the grid's origin) overflowed too.
TEST(Broadphase, GridSpanningTheWholeRange) {
    for (const std::int64_t half : {std::int64_t{0}, std::int64_t{1}})
        for (int k = 0; k < 3; ++k) {
            Scene s;
            const std::int64_t spots[][3] = {{INT64_MIN, 0, 0}, {INT64_MAX, 2, 0},     {INT64_MAX, 2, 2},
                                             {INT64_MIN + 1, 1, 1}, {INT64_MAX - 1, 3, 2}, {0, 0, 0},
                                             {1, 1, 1},           {INT64_MAX, 2, 2}};
            for (const auto& spot : spots) {
                Vec3 p{}, e{};
                for (int j = 0; j < 3; ++j) {
                    set(p, (k + j) % 3, spot[j]);
                    set(e, j, half);
                }
                s.dynamic.push_back(static_cast<BodyId>(s.pos.size()));
                s.pos.push_back(p);
                s.extent.push_back(e);
            }
            const Pairs expected = exact_pairs(s, Fixed::zero());
            ASSERT_FALSE(expected.empty());
            EXPECT_EQ(pairs_of(BroadphaseKind::Grid, s, Fixed::zero()), expected) << "half " << half << " axis " << k;
            // Configured near the origin (grid origin below 0, so a min corner at INT64_MAX minus
            // it overflowed), then moved to the limits (clamped into the outermost cells).
            Scene moved = s;
            for (std::size_t i = 0; i < moved.pos.size(); ++i) {
                const Fixed c = Fixed::from_raw(i % 2 == 0 ? -1 : 1);
                moved.pos[i] = {c, c, c};
            }
            Broadphase bp;
            bp.configure(BroadphaseKind::Grid, moved.dynamic, moved.statics, moved.pos, moved.extent, Fixed::zero());
            std::vector<BodyPair> pairs;
            bp.find_pairs(s.pos, s.extent, pairs);
            EXPECT_EQ(sorted_pairs(pairs), expected) << "moved, half " << half << " axis " << k;
        }
}

}  // namespace
}  // namespace lockroll::sim
