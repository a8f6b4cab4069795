// The grid broadphase against a brute-force reference: it must find exactly the pairs whose
// fattened boxes overlap (no miss, no duplicate, no static-static pair), wherever the bodies have
// moved since configure() (also far outside the grid's bounds, where they are clamped into the
// border cells), and its output must be a pure function of the current positions.
#include "sim/broadphase.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
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

// The static tests come last, static-major (the static bodies ascending, for each its dynamic
// bodies ascending): the sequential grid tests them a block of dynamic bodies at a time, each
// static body's pairs into its own list, and must still emit exactly that order.
TEST(Broadphase, StaticPairsComeStaticMajorInDynamicOrder) {
    const Scene s = make_scene(37, 3000);  // several blocks of dynamic bodies, two static bodies
    Broadphase bp;
    const std::vector<BodyPair> pairs = grid_pairs(s, bp);
    const auto overlapping = brute_force(s, kMargin);
    std::vector<std::pair<BodyId, BodyId>> expected, found;
    for (BodyId st : s.statics)
        for (BodyId d : s.dynamic)
            if (std::binary_search(overlapping.begin(), overlapping.end(), std::pair{std::min(d, st), std::max(d, st)}))
                expected.emplace_back(st, d);
    ASSERT_GT(expected.size(), 300u) << "several blocks must hold static pairs";
    std::size_t first_static = pairs.size();
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        const bool a_static = std::find(s.statics.begin(), s.statics.end(), pairs[i].a) != s.statics.end();
        const bool b_static = std::find(s.statics.begin(), s.statics.end(), pairs[i].b) != s.statics.end();
        if (!a_static && !b_static) continue;
        first_static = std::min(first_static, i);
        found.emplace_back(a_static ? pairs[i].a : pairs[i].b, a_static ? pairs[i].b : pairs[i].a);
    }
    EXPECT_EQ(found, expected);
    EXPECT_EQ(pairs.size() - first_static, found.size()) << "the static pairs are the list's tail";
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

}  // namespace
}  // namespace lockroll::sim
