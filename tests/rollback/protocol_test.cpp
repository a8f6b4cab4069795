// Wire messages: round trips, the run-length coding, frame unwrapping, and hostile bytes (random
// and mutated valid datagrams) that must be rejected and counted, never crash or change state.
#include <gtest/gtest.h>

#include "rollback/protocol.h"
#include "rollback/session.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

InputMessage sample_input() {
    InputMessage m;
    m.ack = 65530;
    m.first_frame = 7;
    m.frame_count = 6;
    m.inputs = {1, 2, 3, 1, 2, 3, 1, 2, 3, 9, 9, 9, 1, 2, 3, 1, 2, 3};
    m.has_time_sync = true;
    m.sender_frame = 12;
    m.advantage = -3;
    m.checksum_count = 2;
    m.checksum_frames[0] = 5;
    m.checksums[0] = 0x0123456789abcdefull;
    m.checksum_frames[1] = 6;
    m.checksums[1] = 0xfedcba9876543210ull;
    return m;
}

TEST(Protocol, InputRoundTripAndRunLength) {
    const InputMessage m = sample_input();
    std::vector<std::uint8_t> bytes;
    encode(m, 3, bytes);
    // kind+flags, ack, first, count, 3 runs of (1 + 3), time sync 3 + stamps 6, two checksums of 6.
    EXPECT_EQ(bytes.size(), 1u + 2 + 2 + 1 + 3 * 4 + 3 + 6 + 2 * 6);
    EXPECT_EQ(bytes[0], 0x51);  // input, time sync, two checksums
    EXPECT_EQ(bytes[1], 0xFA);  // ack 65530 little-endian
    EXPECT_EQ(bytes[2], 0xFF);
    EXPECT_EQ(peek_kind(bytes), MessageKind::Input);
    InputMessage back;
    ASSERT_EQ(decode(bytes, 3, back), nullptr);
    EXPECT_EQ(back.ack, m.ack);
    EXPECT_EQ(back.first_frame, m.first_frame);
    EXPECT_EQ(back.frame_count, m.frame_count);
    EXPECT_EQ(back.inputs, m.inputs);
    EXPECT_TRUE(back.has_time_sync);
    EXPECT_EQ(back.sender_frame, 12);
    EXPECT_EQ(back.advantage, -3);
    ASSERT_EQ(back.checksum_count, 2);
    EXPECT_EQ(back.checksum_frames[0], 5);
    EXPECT_EQ(back.checksums[0], m.checksums[0] & 0xFFFFFFFFu) << "only the low 32 bits travel";
    EXPECT_EQ(back.checksum_frames[1], 6);
    EXPECT_EQ(back.checksums[1], m.checksums[1] & 0xFFFFFFFFu);

    InputMessage bare;
    bare.ack = 3;
    bytes.clear();
    encode(bare, 3, bytes);
    EXPECT_EQ(bytes.size(), 6u);
    ASSERT_EQ(decode(bytes, 3, back), nullptr);
    EXPECT_FALSE(back.has_time_sync);
    EXPECT_EQ(back.checksum_count, 0);
    EXPECT_EQ(back.frame_count, 0);
}

// Version 3: a slot entry's vote bit and the agreement report after the table (issue 21).
TEST(Protocol, VotesAndTheAgreementReportRoundTrip) {
    InputMessage m;
    m.has_extension = true;
    m.slots = {{0, SlotState::Running, 0, 10, false}, {1, SlotState::Disconnected, 3, 11, true}, {2, SlotState::Disconnected, 1, 9, false}};
    m.has_agreement = true;
    m.agreement = {0xA1B2C3D4u, 0x0081, 0x0041, 2, 0x0081, 1};
    std::vector<std::uint8_t> bytes;
    encode(m, 3, bytes);
    // header 6, entry count, 3 entries of 5, agreement 12, block count.
    ASSERT_EQ(bytes.size(), 6u + 1 + 3 * 5 + kAgreementBytes + 1);
    EXPECT_EQ(bytes[6], 0x83) << "three entries, agreement present";
    EXPECT_EQ(bytes[7 + 5 + 1], 0x82) << "disconnected (2), voted";
    EXPECT_EQ(bytes[7 + 10 + 1], 0x02) << "disconnected, applied";
    EXPECT_EQ(bytes[22], 0xD4) << "instance, little-endian";
    InputMessage back;
    ASSERT_EQ(decode(bytes, 3, back), nullptr);
    ASSERT_EQ(back.slots.size(), 3u);
    EXPECT_FALSE(back.slots[0].voted);
    EXPECT_TRUE(back.slots[1].voted);
    EXPECT_FALSE(back.slots[2].voted);
    EXPECT_EQ(back.slots[1].state, SlotState::Disconnected);
    ASSERT_TRUE(back.has_agreement);
    EXPECT_EQ(back.agreement, m.agreement);

    // Without it, a reused message forgets the last one.
    m.has_agreement = false;
    bytes.clear();
    encode(m, 3, bytes);
    ASSERT_EQ(decode(bytes, 3, back), nullptr);
    EXPECT_FALSE(back.has_agreement);

    // A vote is "gone" only; an agreement names a slot (or none) and accepts under a ballot.
    m.has_agreement = true;
    bytes.clear();
    encode(m, 3, bytes);
    auto running_vote = bytes;
    running_vote[7 + 1] = 0x80;
    EXPECT_STREQ(decode(running_vote, 3, back), "input message: a vote that is not \"gone\"");
    auto far_slot = bytes;
    far_slot[22 + 8] = 64;  // accepted slot
    EXPECT_STREQ(decode(far_slot, 3, back), "input message: agreement names no slot");
    auto no_ballot = bytes;
    no_ballot[22 + 6] = no_ballot[22 + 7] = 0;  // accepted ballot 0 with a slot
    EXPECT_STREQ(decode(no_ballot, 3, back), "input message: agreement accepted without a slot");
    auto no_proposal = bytes;
    no_proposal[22 + 9] = no_proposal[22 + 10] = 0;  // proposal 0 naming a slot
    EXPECT_STREQ(decode(no_proposal, 3, back), "input message: agreement slot without a proposal");
    for (std::size_t len = 7; len < bytes.size(); ++len)
        EXPECT_NE(decode(std::span(bytes).first(len), 3, back), nullptr) << "truncated to " << len;
}

TEST(Protocol, QueryAndReplyRoundTrip) {
    std::vector<std::uint8_t> bytes;
    encode(QueryMessage{QueryWhat::BodyHashes, 1234, 128, 100}, bytes);
    EXPECT_EQ(bytes.size(), 12u);
    QueryMessage q;
    ASSERT_EQ(decode(bytes, q), nullptr);
    EXPECT_EQ(q.what, QueryWhat::BodyHashes);
    EXPECT_EQ(q.frame, 1234u);
    EXPECT_EQ(q.start, 128u);
    EXPECT_EQ(q.count, 100);

    ReplyMessage r;
    r.what = QueryWhat::BodyFields;
    r.available = true;
    r.frame = 9;
    r.start = 4;
    r.count = 1;
    r.fields = {-1, 2, -3, 4, -5, 6};
    bytes.clear();
    encode(r, bytes);
    EXPECT_EQ(bytes.size(), 13u + 1 + 48);
    ReplyMessage rb;
    ASSERT_EQ(decode(bytes, rb), nullptr);
    EXPECT_EQ(rb.fields, r.fields);
    EXPECT_TRUE(rb.available);

    ReplyMessage none;
    none.what = QueryWhat::FrameChecksums;
    none.frame = 3;
    none.count = 5;
    bytes.clear();
    encode(none, bytes);
    EXPECT_EQ(bytes.size(), 13u);
    ASSERT_EQ(decode(bytes, rb), nullptr);
    EXPECT_FALSE(rb.available);
    EXPECT_TRUE(rb.values.empty());
}

TEST(Protocol, DecodeRejectsMalformed) {
    std::vector<std::uint8_t> good;
    encode(sample_input(), 3, good);
    InputMessage m;
    for (std::size_t len = 0; len < good.size(); ++len)
        EXPECT_NE(decode(std::span(good).first(len), 3, m), nullptr) << "truncated to " << len;
    auto extra = good;
    extra.push_back(0);
    EXPECT_STREQ(decode(extra, 3, m), "input message: trailing bytes");
    auto zero_run = good;
    zero_run[6] = 0;  // first run length
    EXPECT_STREQ(decode(zero_run, 3, m), "input message: empty input run");
    auto long_run = good;
    long_run[6] = 200;
    EXPECT_STREQ(decode(long_run, 3, m), "input message: runs exceed frame count");
    auto flags = good;
    flags[0] |= 0x80;  // extension announced, none present
    EXPECT_STREQ(decode(flags, 3, m), "input message: truncated extension");
    EXPECT_FALSE(peek_kind(std::vector<std::uint8_t>{0x09}).has_value());
    EXPECT_FALSE(peek_kind(std::vector<std::uint8_t>{}).has_value());

    QueryMessage q;
    std::vector<std::uint8_t> query;
    encode(QueryMessage{QueryWhat::BodyFields, 1, 2, 1}, query);
    auto big = query;
    big[10] = 2;  // count 2 for body fields
    EXPECT_NE(decode(big, q), nullptr);
    auto what = query;
    what[1] = 9;
    EXPECT_NE(decode(what, q), nullptr);

    ReplyMessage r;
    r.what = QueryWhat::BodyHashes;
    r.available = true;
    r.frame = 1;
    r.start = 0;
    r.count = 3;
    r.values = {1, 2, 3};
    std::vector<std::uint8_t> reply;
    encode(r, reply);
    ReplyMessage rb;
    EXPECT_NE(decode(std::span(reply).first(reply.size() - 1), rb), nullptr);
    auto lying = reply;
    lying[11] = 0xFF;  // count 255 > limit
    EXPECT_NE(decode(lying, rb), nullptr);
}

TEST(Protocol, UnwrapFrame) {
    EXPECT_EQ(unwrap_frame(5, 3), 5u);
    EXPECT_EQ(unwrap_frame(65535, 65536 + 2), 65535u);
    EXPECT_EQ(unwrap_frame(2, 65535), 65538u);
    EXPECT_EQ(unwrap_frame(0, 65536 * 3), 65536u * 3);
    EXPECT_FALSE(unwrap_frame(65000, 10).has_value());  // would be negative
    for (std::uint32_t ref : {0u, 100u, 40000u, 70000u, 1000000u})
        for (std::int64_t d : {-30000, -1, 0, 1, 30000}) {
            const std::int64_t f = std::int64_t{ref} + d;
            if (f < 0) continue;
            EXPECT_EQ(unwrap_frame(static_cast<std::uint16_t>(f), ref), static_cast<std::uint32_t>(f));
        }
}

TEST(Protocol, RandomBytesNeverCrashTheDecoders) {
    sim::SplitMix64 rng(1234);
    InputMessage im;
    QueryMessage qm;
    ReplyMessage rm;
    int accepted = 0;
    for (int i = 0; i < 200000; ++i) {
        std::vector<std::uint8_t> b(rng.below(80));
        for (auto& x : b) x = static_cast<std::uint8_t>(rng.next());
        if (!b.empty() && rng.below(2)) b[0] = static_cast<std::uint8_t>(1 + rng.below(3)) | (b[0] & 0x30);
        accepted += decode(b, 3, im) == nullptr;
        accepted += decode(b, qm) == nullptr;
        accepted += decode(b, rm) == nullptr;
    }
    // Most random byte strings are garbage; a few happen to be well-formed, which is fine.
    EXPECT_LT(accepted, 200000 / 10);
}

// Hostile traffic at the session level: a victim session (player 0 of a 3-player game) gets the
// real datagrams sent to player 0 plus mutated copies and plain noise. A mutation that still
// decodes is, as far as anyone can tell, what the peer said; the point here is that nothing
// crashes or throws, bad datagrams are counted, and the victim keeps playing.
TEST(Protocol, SessionSurvivesFuzzedPeers) {
    const auto scene = testing::make_scene(3, 10);
    SessionConfig cfg;
    cfg.players = 3;
    testing::NetParams net;
    net.latency_us = 30000;
    testing::Cluster cluster(scene, cfg, net, 31);
    SessionConfig vcfg = cfg;
    vcfg.max_bad_packets = 1000000;  // keep listening: every datagram must be decoded
    WorldSimulation vsim(scene, 3);
    Session victim(vcfg, vsim);
    sim::SplitMix64 rng(77);
    std::uint64_t mutated = 0;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (to != 0) return true;
        victim.receive(from, b, cluster.now());
        if (from != 2) return true;
        for (int k = 0; k < 4; ++k) {
            auto bad = b;
            const int what = static_cast<int>(rng.below(4));
            if (what == 0 && !bad.empty()) {
                bad.resize(rng.below(bad.size()));
            } else if (what == 1) {
                bad.push_back(static_cast<std::uint8_t>(rng.next()));
            } else {
                for (int f = 0; f < 1 + static_cast<int>(rng.below(3)); ++f)
                    if (!bad.empty()) bad[rng.below(bad.size())] ^= static_cast<std::uint8_t>(1u << rng.below(8));
            }
            ++mutated;
            victim.receive(2, bad, cluster.now());
        }
        std::vector<std::uint8_t> noise(rng.below(40));
        for (auto& x : noise) x = static_cast<std::uint8_t>(rng.next());
        victim.receive(2, noise, cluster.now());
        victim.receive(9, noise, cluster.now());  // no such player
        return true;
    };
    testing::WalkBot bot(5);
    std::vector<Datagram> out;
    cluster.before_tick = [&](PlayerId id, testing::Client&) {
        if (id != 0) return;
        victim.advance(bot.next(), cluster.now());
        out.clear();
        victim.poll(cluster.now(), out);  // goes nowhere
    };
    cluster.run_frames(300);
    const auto& st = victim.stats();
    EXPECT_GT(st.peers[2].malformed_packets, mutated / 4);
    EXPECT_GT(st.unknown_peer_packets, 0u);
    EXPECT_FALSE(st.peers[2].error);
    EXPECT_GT(victim.frame(), 250u);
    // The game itself was untouched.
    for (const auto& c : cluster.clients) EXPECT_TRUE(c->desyncs.empty());
}

TEST(Protocol, PeerEntersStickyErrorAfterTooManyBadPackets) {
    const auto scene = testing::make_scene(2, 4);
    WorldSimulation sim(scene, 2);
    testing::Client dummy(scene, SessionConfig{}, 1);
    SessionConfig cfg;
    cfg.max_bad_packets = 5;
    struct Obs : SessionObserver {
        int errors = 0;
        void on_peer_error(PlayerId, const std::string&) override { ++errors; }
    } obs;
    Session s(cfg, sim, &obs);
    const std::vector<std::uint8_t> junk{0x01, 0x02};
    for (int i = 0; i < 20; ++i) s.receive(1, junk, 0);
    EXPECT_TRUE(s.peer_error(1));
    EXPECT_EQ(obs.errors, 1);
    EXPECT_EQ(s.stats().peers[1].malformed_packets, 5u);
    EXPECT_EQ(s.stats().peers[1].ignored_packets, 15u);
    // A perfectly good datagram is ignored too now, and nothing is sent to that peer.
    std::vector<Datagram> out;
    dummy.session->advance(std::array<std::uint8_t, 3>{}, 0);
    dummy.session->poll(0, out);
    s.receive(1, out[0].bytes, 0);
    EXPECT_EQ(s.stats().peers[1].ignored_packets, 16u);
    out.clear();
    s.poll(0, out);
    EXPECT_TRUE(out.empty());
}

TEST(Protocol, ContradictingInputIsMalformed) {
    const auto scene = testing::make_scene(2, 4);
    WorldSimulation sim(scene, 2);
    Session s(SessionConfig{}, sim);
    InputMessage m;
    m.first_frame = 0;
    m.frame_count = 2;
    m.inputs = {1, 1, 1, 2, 2, 2};
    std::vector<std::uint8_t> b;
    encode(m, 3, b);
    s.receive(1, b, 0);
    EXPECT_EQ(s.stats().peers[1].malformed_packets, 0u);
    m.inputs = {1, 1, 1, 3, 3, 3};  // frame 1 rewritten
    b.clear();
    encode(m, 3, b);
    s.receive(1, b, 0);
    EXPECT_EQ(s.stats().peers[1].malformed_packets, 1u);
    // Acknowledging local inputs that were never sent is a lie too.
    InputMessage ack;
    ack.ack = 50;
    b.clear();
    encode(ack, 3, b);
    s.receive(1, b, 0);
    EXPECT_EQ(s.stats().peers[1].malformed_packets, 2u);
}

}  // namespace
}  // namespace lockroll::rollback
