// Snapshot contract (sim/snapshot.h): canonical bytes, round trips, load-then-step equals
// never saving, failure modes leave the world unchanged, per-body hashes narrow differences.
#include <gtest/gtest.h>

#include <vector>

#include "sim/snapshot.h"
#include "sim/world.h"

namespace lockroll::sim {
namespace {

Fixed fx(const char* text) { return *Fixed::parse(text); }

SceneDesc small_room(int balls, bool players) {
    SceneDesc s;
    add_room(s, {fx("-4"), fx("0"), fx("-4")}, {fx("4"), fx("4"), fx("4")}, Fixed::one());
    if (players) {
        for (int p = 0; p < 2; ++p) {
            BodyDesc b;
            b.shape = Shape::Box;
            b.half_extents = {fx("0.4"), fx("0.9"), fx("0.4")};
            b.position = {Fixed::from_int(p * 4 - 2), fx("0.9"), Fixed::zero()};
            b.mass = fx("5");
            b.player = p;
            s.bodies.push_back(b);
        }
    }
    SpawnerDesc sp;
    sp.count = balls;
    sp.radius = fx("0.25");
    sp.region_min = {fx("-3.5"), fx("0.5"), fx("-3.5")};
    sp.region_max = {fx("3.5"), fx("3.5"), fx("3.5")};
    sp.max_speed = fx("5");
    sp.seed = 11;
    expand_spawner(s, sp);
    return s;
}

std::vector<PlayerInput> scripted(int frame, int players) {
    std::vector<PlayerInput> in(static_cast<std::size_t>(players));
    for (int p = 0; p < players; ++p)
        in[static_cast<std::size_t>(p)] = {static_cast<std::int8_t>(((frame / 7 + p) % 3 - 1) * 100),
                                           static_cast<std::int8_t>(((frame / 11 + 2 * p) % 3 - 1) * 127),
                                           static_cast<std::int8_t>(frame % 40 == 0 ? 127 : 0)};
    return in;
}

std::vector<std::uint8_t> save_vec(const World& w) {
    std::vector<std::uint8_t> buf(snapshot_size(w));
    save(w, buf);
    return buf;
}

TEST(Snapshot, SizeIs48BytesPerDynamicBodyPlusHeader) {
    World w(small_room(20, true));
    EXPECT_EQ(snapshot_size(w), 24u + 48u * 22u);
}

TEST(Snapshot, HeaderIsCanonicalLittleEndian) {
    World w(small_room(3, false));
    for (int f = 0; f < 5; ++f) w.step({});
    const auto buf = save_vec(w);
    EXPECT_EQ(buf[0], 'L');
    EXPECT_EQ(buf[1], 'R');
    EXPECT_EQ(buf[2], 'S');
    EXPECT_EQ(buf[3], '1');
    EXPECT_EQ(buf[4], 3);  // dynamic count, little-endian
    EXPECT_EQ(buf[8], 5);  // frame
    // First body's position.x as little-endian int64.
    std::uint64_t x = 0;
    for (int i = 0; i < 8; ++i) x |= std::uint64_t{buf[24 + i]} << (8 * i);
    EXPECT_EQ(static_cast<std::int64_t>(x), w.position(w.dynamic_ids()[0]).x.raw);
}

TEST(Snapshot, SaveStepLoadStepIsIdenticalEveryFrame) {
    // Side by side: save at frame f, step 120 frames recording checksums, load, step again.
    World w(small_room(30, true));
    for (int f = 0; f < 50; ++f) w.step(scripted(f, 2));
    const auto snap = save_vec(w);
    std::vector<std::uint64_t> first;
    for (int f = 50; f < 170; ++f) {
        w.step(scripted(f, 2));
        first.push_back(checksum(w));
    }
    ASSERT_EQ(load(w, snap), "");
    EXPECT_EQ(w.frame(), 50u);
    for (int f = 50; f < 170; ++f) {
        w.step(scripted(f, 2));
        ASSERT_EQ(checksum(w), first[static_cast<std::size_t>(f - 50)]) << "frame " << f + 1;
    }
}

TEST(Snapshot, LoadIntoFreshWorldContinuesIdentically) {
    const SceneDesc scene = small_room(30, true);
    World a(scene), b(scene);
    for (int f = 0; f < 80; ++f) a.step(scripted(f, 2));
    ASSERT_EQ(load(b, save_vec(a)), "");
    EXPECT_EQ(checksum(a), checksum(b));
    for (int f = 80; f < 200; ++f) {
        a.step(scripted(f, 2));
        b.step(scripted(f, 2));
    }
    EXPECT_EQ(save_vec(a), save_vec(b));
}

TEST(Snapshot, GridBroadphaseAlsoRoundTrips) {
    SceneDesc scene = small_room(60, false);
    scene.broadphase = BroadphaseKind::Grid;
    World w(scene);
    for (int f = 0; f < 20; ++f) w.step({});
    const auto snap = save_vec(w);
    for (int f = 0; f < 60; ++f) w.step({});
    const auto expected = save_vec(w);
    ASSERT_EQ(load(w, snap), "");
    for (int f = 0; f < 60; ++f) w.step({});
    EXPECT_EQ(save_vec(w), expected);
}

TEST(Snapshot, ChecksumIsXxh3OfTheSnapshotAndChangesWithAnyBit) {
    World w(small_room(10, false));
    w.step({});
    const std::uint64_t c = checksum(w);
    EXPECT_EQ(checksum(w), c) << "checksum is a pure function of state";
    w.flip_bit(w.dynamic_ids()[3], 4, 0);
    EXPECT_NE(checksum(w), c);
}

TEST(Snapshot, BadBuffersAreRejectedAndLeaveTheWorldUnchanged) {
    World w(small_room(10, false));
    for (int f = 0; f < 10; ++f) w.step({});
    const auto good = save_vec(w);
    World other(small_room(10, false));
    const auto before = save_vec(other);

    auto bad = good;
    bad.pop_back();
    EXPECT_NE(load(other, bad), "");
    bad = good;
    bad[0] ^= 1;
    EXPECT_NE(load(other, bad), "");
    bad = good;
    bad[4] = 9;  // body count
    EXPECT_NE(load(other, bad), "");
    EXPECT_NE(load(other, std::vector<std::uint8_t>(5)), "");
    World bigger(small_room(11, false));
    EXPECT_NE(load(bigger, good), "");
    EXPECT_EQ(save_vec(other), before);

    std::vector<std::uint8_t> small(good.size() - 1);
    EXPECT_THROW(save(w, small), std::length_error);
}

TEST(Snapshot, FirstDifferenceNamesBodyAndField) {
    World a(small_room(10, false));
    a.step({});
    const auto s0 = save_vec(a);
    EXPECT_EQ(first_difference(s0, s0, nullptr), -1);
    a.flip_bit(a.dynamic_ids()[6], 5, 17);  // velocity.z of the 7th dynamic body
    const auto s1 = save_vec(a);
    int field = -2;
    EXPECT_EQ(first_difference(s0, s1, &field), 6);
    EXPECT_EQ(field, 5);
    EXPECT_STREQ(kBodyFieldNames[field], "velocity.z");
}

TEST(Snapshot, BodyHashesDifferOnlyForTheChangedBody) {
    World a(small_room(10, false));
    a.step({});
    std::vector<std::uint64_t> before;
    for (BodyId id : a.dynamic_ids()) before.push_back(body_hash(a, id));
    const BodyId victim = a.dynamic_ids()[2];
    a.flip_bit(victim, 1, 40);
    for (std::size_t k = 0; k < a.dynamic_ids().size(); ++k) {
        const BodyId id = a.dynamic_ids()[k];
        if (id == victim)
            EXPECT_NE(body_hash(a, id), before[k]);
        else
            EXPECT_EQ(body_hash(a, id), before[k]);
    }
}

}  // namespace
}  // namespace lockroll::sim
