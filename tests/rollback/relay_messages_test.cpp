// The relay messages (rollback/relay_messages.h) against docs/wire-format.md, "Relay messages":
// sizes, round trips, delta coding, and every kind of malformed datagram refused.
#include <gtest/gtest.h>

#include "rollback/relay_messages.h"

namespace lockroll::rollback {
namespace {

TEST(RelayMessages, SizesAreTheDocumentedOnes) {
    std::vector<std::uint8_t> b;
    encode(RelayHello{}, b);
    EXPECT_EQ(b.size(), 47u);  // version 3: also_slots; a u16 token length, here 0
    b.clear();
    RelayHello with_token;
    with_token.token.assign(82, 7);
    encode(with_token, b);
    EXPECT_EQ(b.size(), 47u + 82u);
    b.clear();
    encode(RelayWelcome{}, b);
    EXPECT_EQ(b.size(), 30u);
    b.clear();
    encode(RelayNotice{}, b);
    EXPECT_EQ(b.size(), 15u);
    b.clear();
    RelayFrames f;
    f.players = 2;
    f.input_size = 3;
    encode(f, b);
    EXPECT_EQ(b.size(), 25u);  // the header alone
}

TEST(RelayMessages, HelloAndWelcomeRoundTrip) {
    RelayHello h;
    h.room_id = 0x1122334455667788;
    h.scene_checksum = 99;
    h.players = 4;
    h.input_size = 5;
    h.tick_rate = 30;
    h.role = RelayRole::Joiner;
    h.slot = 3;
    h.absent_slots = 0x8;
    h.incarnation = 777;
    h.stamp_us = 123456;
    h.token = {1, 2, 3, 250};
    std::vector<std::uint8_t> b;
    encode(h, b);
    RelayHello g;
    ASSERT_EQ(decode(b, g), nullptr);
    EXPECT_EQ(g.room_id, h.room_id);
    EXPECT_EQ(g.token, h.token);
    EXPECT_EQ(g.role, RelayRole::Joiner);
    EXPECT_EQ(g.absent_slots, 0x8);
    EXPECT_EQ(g.incarnation, 777u);
    b.back() ^= 0;  // still fine
    b.push_back(0);
    EXPECT_NE(decode(b, g), nullptr);  // trailing byte
    b.pop_back();
    b.pop_back();
    EXPECT_NE(decode(b, g), nullptr);  // token shorter than its length says
    b.push_back(250);
    b[24 - 1] = 9;                     // role byte out of range
    EXPECT_NE(decode(b, g), nullptr);
    b[24 - 1] = 1;
    b[45] = 0x01;                      // token length 257: over kRelayMaxTokenBytes
    b[46] = 0x01;
    EXPECT_NE(decode(b, g), nullptr);
    RelayHello too_long;
    too_long.token.assign(kRelayMaxTokenBytes + 1, 0);
    std::vector<std::uint8_t> c;
    EXPECT_THROW(encode(too_long, c), std::invalid_argument);
}

TEST(RelayMessages, HelloNamesSeveralSlotsLowestFirst) {
    RelayHello h;
    h.players = 4;
    h.slot = 1;
    h.also_slots = 0x4 | 0x8;  // slots 2 and 3 too
    std::vector<std::uint8_t> b;
    encode(h, b);
    RelayHello g;
    ASSERT_EQ(decode(b, g), nullptr);
    EXPECT_EQ(g.also_slots, 0xC);
    EXPECT_EQ(relay_hello_slots(g), 0xE);
    EXPECT_EQ(relay_slot_count(relay_hello_slots(g)), 3);
    // Another encoding of the same set (slot 2, also 1 and 3) is malformed: `slot` is the lowest.
    RelayHello other = h;
    other.slot = 2;
    other.also_slots = 0x2 | 0x8;
    b.clear();
    encode(other, b);
    EXPECT_STREQ(decode(b, g), "relay hello: further slots must be above the first");
    other.also_slots = 0x4;  // itself again
    b.clear();
    encode(other, b);
    EXPECT_NE(decode(b, g), nullptr);
    RelayHello spectator;
    spectator.role = RelayRole::Spectator;
    spectator.also_slots = 0x2;
    b.clear();
    encode(spectator, b);
    EXPECT_STREQ(decode(b, g), "relay hello: a spectator plays no slot");
    spectator.also_slots = 0;
    EXPECT_EQ(relay_hello_slots(spectator), 0);
}

TEST(RelayMessages, HelloOfAnotherVersionDecodesToItsVersionAlone) {
    // A version-2 client's hello (no also_slots field: 45 bytes): decoded to its version only, so
    // the server can refuse it with refusal 1, naming the reason, instead of counting it bad.
    RelayHello h;
    h.room_id = 5;
    h.slot = 1;
    std::vector<std::uint8_t> b;
    encode(h, b);
    b.erase(b.begin() + 25, b.begin() + 27);  // drop also_slots: the v2 layout
    b[1] = 2;
    b[2] = 0;
    RelayHello g;
    g.room_id = 99;  // stale from an earlier hello: must not survive
    ASSERT_EQ(decode(b, g), nullptr);
    EXPECT_EQ(g.version, 2);
    EXPECT_EQ(g.room_id, 0u);
    EXPECT_EQ(g.slot, 0);
    EXPECT_NE(decode(std::span(b).first(2), g), nullptr);  // not even a version
}

// Four frames of a room of three players with 2-byte inputs: an absent slot, a replaced one, an
// unchanged frame, one changed input (the delta coding's cases).
RelayFrames four_frames_of_three() {
    RelayFrames f;
    f.players = 3;
    f.input_size = 2;
    f.first_frame = 1000;
    f.frame_count = 4;
    f.server_frame = 1003;
    f.input_ack = 1006;
    f.flags = {0, kRelayAbsent, 0, 0, kRelayAbsent, 0, 0, kRelayAbsent, kRelayReplaced, 0, kRelayAbsent, kRelayReplaced};
    f.inputs = {1, 1, 0, 0, 5, 5, 1, 1, 0, 0, 5, 5, 1, 1, 0, 0, 5, 5, 2, 2, 0, 0, 5, 5};
    return f;
}

TEST(RelayMessages, FramesAreDeltaCodedAndRoundTrip) {
    const RelayFrames f = four_frames_of_three();
    std::vector<std::uint8_t> b;
    encode(f, b);
    // Frame 0: slots 0 and 2 and the absent slot 1 (flags != 0) listed; frame 1: nothing
    // changed; frame 2: slot 2's flag; frame 3: slot 0's input.
    EXPECT_EQ(b.size(), 25u + (1 + 3 * 3) + 1 + (1 + 3) + (1 + 3));
    RelayFrames g;
    ASSERT_EQ(decode(b, 3, 2, g), nullptr);
    EXPECT_EQ(g.flags, f.flags);
    EXPECT_EQ(g.inputs, f.inputs);
    EXPECT_EQ(g.first_frame, 1000u);
    EXPECT_NE(decode(b, 4, 2, g), nullptr);  // another room's sizes
    auto bad = b;
    bad[25] |= 0x80;  // a mask bit past the room's slots
    EXPECT_NE(decode(bad, 3, 2, g), nullptr);
    for (std::size_t n = 0; n < b.size(); ++n)
        EXPECT_NE(decode(std::span(b).first(n), 3, 2, g), nullptr) << "truncated to " << n;
}

// The relay server encodes Frames straight from its history's records (flags then inputs per
// frame): the bytes are encode()'s for the same frames, and a record read out of place shows.
TEST(RelayMessages, FramesFromRecordsAreTheSameBytes) {
    RelayFrames f = four_frames_of_three();
    f.stamp = 77;
    f.echo = 5;
    f.hold = 9;
    std::vector<std::uint8_t> records;  // per frame: 3 flags, then 3 x 2 inputs
    for (std::size_t i = 0; i < 4; ++i) {
        records.insert(records.end(), f.flags.begin() + static_cast<std::ptrdiff_t>(i * 3), f.flags.begin() + static_cast<std::ptrdiff_t>(i * 3 + 3));
        records.insert(records.end(), f.inputs.begin() + static_cast<std::ptrdiff_t>(i * 6), f.inputs.begin() + static_cast<std::ptrdiff_t>(i * 6 + 6));
    }
    std::vector<std::uint8_t> want, got;
    encode(f, want);
    RelayFrames header = f;
    header.flags.clear();
    header.inputs.clear();
    const auto record = [](const void* c, std::uint32_t i) { return static_cast<const std::uint8_t*>(c) + i * 9; };
    encode_frames(header, records.data(), record, got);
    EXPECT_EQ(got, want);
    records[9 * 3 + 3] ^= 1;  // frame 3, slot 0's first input byte
    got.clear();
    encode_frames(header, records.data(), record, got);
    EXPECT_NE(got, want);
}

TEST(RelayMessages, InputForwardNoticeRoundTripAndLimits) {
    RelayInput m;
    m.confirmed_ack = kRelayNoFrames;
    m.first_frame = 70000;
    m.frame_count = 2;
    m.slots = 0x1;
    m.inputs = {1, 2, 3, 4, 5, 6};
    m.checksum_count = 1;
    m.checksum_frames[0] = 60;
    m.checksums[0] = 0xABCDEF0123456789;
    std::vector<std::uint8_t> b;
    encode(m, 3, b);
    RelayInput g;
    ASSERT_EQ(decode(b, 3, g), nullptr);
    EXPECT_EQ(g.first_frame, 70000u);
    EXPECT_EQ(g.inputs, m.inputs);
    EXPECT_EQ(g.checksums[0], m.checksums[0]);
    EXPECT_NE(decode(b, 4, g), nullptr);  // another input size does not parse
    RelayInput many;
    many.slots = 0x1;
    many.frame_count = static_cast<std::uint8_t>(relay_max_inputs(3) + 1);
    many.inputs.assign(many.frame_count * 3u, 0);
    EXPECT_THROW(encode(many, 3, b), std::invalid_argument);
    // Records of two slots: 2 frames x 2 slots x 3 bytes, sized by the mask.
    RelayInput two;
    two.slots = 0x5;  // slots 0 and 2
    two.frame_count = 2;
    two.inputs = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    b.clear();
    encode(two, 3, b);
    ASSERT_EQ(decode(b, 3, g), nullptr);
    EXPECT_EQ(g.slots, 0x5);
    EXPECT_EQ(g.inputs, two.inputs);
    b[10] = 0;  // the mask now names no slot, while two records follow
    b[11] = 0;
    EXPECT_STREQ(decode(b, 3, g), "relay input: inputs for no slot");
    EXPECT_EQ(relay_max_inputs(16 * kRelayMaxInputSize), 1);  // every slot's largest input fits one record
    RelayInput none;  // a spectator's: no records, no slots
    b.clear();
    encode(none, 3, b);
    ASSERT_EQ(decode(b, 3, g), nullptr);
    two.slots = 0x1;  // the inputs no longer fit the mask
    EXPECT_THROW(encode(two, 3, b), std::invalid_argument);

    RelayForward f;
    f.slot = 4;
    f.payload.assign(kRelayMaxForwardBytes, 7);
    b.clear();
    encode(f, b);
    EXPECT_LE(b.size(), kRelayMaxDatagramBytes);
    RelayForward h;
    ASSERT_EQ(decode(b, h), nullptr);
    EXPECT_EQ(h.payload.size(), kRelayMaxForwardBytes);
    b[2] = 0xFF;  // length beyond the limit
    b[3] = 0xFF;
    EXPECT_NE(decode(b, h), nullptr);

    RelayNotice n;
    n.kind = RelayNoticeKind::Desync;
    n.slot = 2;
    n.frame = 120;
    n.detail = 5;
    b.clear();
    encode(n, b);
    RelayNotice k;
    ASSERT_EQ(decode(b, k), nullptr);
    EXPECT_EQ(k.frame, 120u);
    b[1] = 0;  // no notice kind 0
    EXPECT_NE(decode(b, k), nullptr);
    EXPECT_FALSE(peek_relay_kind(std::vector<std::uint8_t>{1}).has_value());  // a peer-to-peer kind
    EXPECT_FALSE(peek_relay_kind({}).has_value());
}

}  // namespace
}  // namespace lockroll::rollback
