// Replays: a recorded session run verifies offline; corruption and truncation are rejected with
// what and where; a wrong checksum is reported with its frame.
#include <gtest/gtest.h>

#include "rollback/replay.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;

Replay recorded_run(std::uint32_t frames) {
    const auto scene = make_scene(2, 20);
    SessionConfig cfg;
    testing::NetParams net;
    net.latency_us = 50000;
    net.loss_ppm = 50000;
    Cluster cluster(scene, cfg, net, 21);
    cluster.run_frames(frames + 10);
    cluster.settle(frames);
    Replay r = cluster.clients[1]->recorder.replay();
    r.inputs.resize(std::size_t{frames} * r.players * r.input_size);
    r.checksums.resize(frames);
    r.scene_text = "{\"opaque\": \"scene text\"}";
    return r;
}

TEST(Replay, RoundTripAndVerify) {
    const Replay r = recorded_run(600);  // three blocks (256 + 256 + 88)
    const auto bytes = encode_replay(r);
    Replay back;
    const auto err = decode_replay(bytes, back);
    ASSERT_FALSE(err.has_value()) << err->what;
    EXPECT_EQ(back.players, 2u);
    EXPECT_EQ(back.input_size, 3u);
    EXPECT_EQ(back.tick_rate, 60u);
    EXPECT_EQ(back.frames(), 600u);
    EXPECT_EQ(back.inputs, r.inputs);
    EXPECT_EQ(back.checksums, r.checksums);
    EXPECT_EQ(back.scene_text, r.scene_text);
    EXPECT_EQ(back.initial_checksum, r.initial_checksum);
    WorldSimulation sim(make_scene(2, 20), 2);
    const auto mismatch = verify_replay(back, sim);
    EXPECT_FALSE(mismatch.has_value()) << "frame " << mismatch->frame;
}

TEST(Replay, WrongChecksumNamesTheFirstBadFrame) {
    Replay r = recorded_run(300);
    r.checksums[199] ^= 1;  // frame 200
    r.checksums[250] ^= 1;
    WorldSimulation sim(make_scene(2, 20), 2);
    const auto mismatch = verify_replay(r, sim);
    ASSERT_TRUE(mismatch.has_value());
    EXPECT_EQ(mismatch->frame, 200u);
    EXPECT_NE(mismatch->recorded, mismatch->replayed);

    Replay wrong_scene = recorded_run(10);
    WorldSimulation other(make_scene(2, 21), 2);
    const auto m0 = verify_replay(wrong_scene, other);
    ASSERT_TRUE(m0.has_value());
    EXPECT_EQ(m0->frame, 0u);  // the initial state already differs
}

TEST(Replay, CorruptionIsLocatedAndTruncationNamed) {
    const Replay r = recorded_run(600);
    const auto good = encode_replay(r);
    Replay out;

    // A flipped byte in block 1 (frames 256..511).
    const std::size_t header = good.size() - (600 * 14 + 3 * 8);
    auto bad = good;
    bad[header + 300 * 14 + 5] ^= 0x40;
    auto err = decode_replay(bad, out);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->what.find("block 1 (frames 256..511"), std::string::npos) << err->what;
    EXPECT_NE(err->what.find("corrupted"), std::string::npos);
    EXPECT_EQ(err->offset, header + 256 * 14 + 8);

    // A flipped bit in the header (the tick rate) fails the header check.
    bad = good;
    bad[16] ^= 0x01;
    err = decode_replay(bad, out);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->what.find("header"), std::string::npos) << err->what;

    // Truncations anywhere: never accepted, always called truncated (or too short).
    for (std::size_t len : {std::size_t{0}, std::size_t{10}, std::size_t{40}, header - 3, header + 100,
                            good.size() - 1}) {
        err = decode_replay(std::span(good).first(len), out);
        ASSERT_TRUE(err.has_value()) << "length " << len;
        EXPECT_NE(err->what.find("truncated"), std::string::npos) << err->what;
    }

    // Trailing garbage.
    bad = good;
    bad.push_back(0);
    err = decode_replay(bad, out);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->what.find("unexpected bytes"), std::string::npos);
    EXPECT_EQ(err->offset, good.size());

    // Not a replay at all.
    bad = good;
    bad[0] = 'X';
    err = decode_replay(bad, out);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->what.find("magic"), std::string::npos);
    EXPECT_EQ(err->offset, 0u);

    // A future version.
    bad = good;
    bad[4] = 2;
    err = decode_replay(bad, out);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->what.find("version 2"), std::string::npos);
}

TEST(Replay, RandomDamageNeverCrashesOrPasses) {
    const Replay r = recorded_run(100);
    const auto good = encode_replay(r);
    sim::SplitMix64 rng(99);
    Replay out;
    for (int i = 0; i < 2000; ++i) {
        auto bad = good;
        const int flips = 1 + static_cast<int>(rng.below(4));
        for (int k = 0; k < flips; ++k)
            bad[rng.below(bad.size())] ^= static_cast<std::uint8_t>(1u << rng.below(8));
        if (bad == good) continue;
        EXPECT_TRUE(decode_replay(bad, out).has_value());
    }
}

TEST(Replay, RecorderInsistsOnOrder) {
    Replay h;
    h.players = 2;
    h.input_size = 3;
    ReplayRecorder rec(h);
    const std::vector<std::uint8_t> in(6, 0);
    rec.add(1, in, 5);
    EXPECT_THROW(rec.add(3, in, 5), std::logic_error);
    EXPECT_THROW(rec.add(2, std::vector<std::uint8_t>(5), 5), std::logic_error);
}

}  // namespace
}  // namespace lockroll::rollback
