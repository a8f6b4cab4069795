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
}  // namespace
}  // namespace lockroll::sim
