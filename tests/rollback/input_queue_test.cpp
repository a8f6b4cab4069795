// InputQueue on its own (rollback/input_queue.h): the confirmed prefix, what each frame was
// simulated with, the ring and its floor, and input from the network that is wrong in every way
// a datagram can be (wrong size, far future, far past, repeated, rewritten). Every add returns a
// verdict and never asserts: the session feeds this straight from packets.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "rollback/input_queue.h"

namespace lockroll::rollback {
namespace {

using Add = InputQueue::Add;
using Bytes = std::vector<std::uint8_t>;

// A 2-byte input that names its frame, so a slot holding the wrong frame shows.
Bytes input_of(std::uint32_t frame) {
    return {static_cast<std::uint8_t>(frame), static_cast<std::uint8_t>(0x80 | (frame >> 8))};
}
Bytes bytes(std::span<const std::uint8_t> s) { return {s.begin(), s.end()}; }

// Confirms frames [from, to) with input_of(frame); every one must be stored.
void confirm_range(InputQueue& q, std::uint32_t from, std::uint32_t to) {
    for (std::uint32_t f = from; f < to; ++f) ASSERT_EQ(q.add_confirmed(f, input_of(f)), Add::Stored) << "frame " << f;
}

TEST(InputQueue, ConstructionChecksItsPreconditions) {
    EXPECT_THROW(InputQueue(0, 8), std::invalid_argument);  // an input of no bytes
    EXPECT_THROW(InputQueue(2, 0), std::invalid_argument);
    EXPECT_THROW(InputQueue(2, 1), std::invalid_argument);  // a power of two, but below 2
    EXPECT_THROW(InputQueue(2, 6), std::invalid_argument);  // not a power of two
    const InputQueue q(3, 16);
    EXPECT_EQ(q.input_size(), 3u);
    EXPECT_EQ(q.capacity(), 16u);
    EXPECT_EQ(q.confirmed_count(), 0u);
    EXPECT_EQ(q.floor(), 0u);
    EXPECT_TRUE(q.last_confirmed().empty());
    EXPECT_FALSE(q.last_absent());
}

TEST(InputQueue, ConfirmsOnlyInOrderAndGapsAreDropped) {
    InputQueue q(2, 16);
    // Frames 1 and 2 arrive before 0: both are dropped, not buffered (the sender resends).
    EXPECT_EQ(q.add_confirmed(2, input_of(2)), Add::Gap);
    EXPECT_EQ(q.add_confirmed(1, input_of(1)), Add::Gap);
    EXPECT_EQ(q.confirmed_count(), 0u);
    EXPECT_TRUE(q.last_confirmed().empty());
    EXPECT_EQ(q.add_confirmed(0, input_of(0)), Add::Stored);
    EXPECT_EQ(q.confirmed_count(), 1u);
    // Frame 2 is still a gap: frame 1 was never stored.
    EXPECT_EQ(q.add_confirmed(2, input_of(2)), Add::Gap);
    EXPECT_EQ(q.add_confirmed(1, input_of(1)), Add::Stored);
    EXPECT_EQ(q.add_confirmed(2, input_of(2)), Add::Stored);
    EXPECT_EQ(q.confirmed_count(), 3u);
    for (std::uint32_t f = 0; f < 3; ++f) EXPECT_EQ(bytes(q.confirmed(f)), input_of(f)) << "frame " << f;
    EXPECT_EQ(bytes(q.last_confirmed()), input_of(2));
}

TEST(InputQueue, ConfirmedInputsNeverChange) {
    InputQueue q(2, 16);
    confirm_range(q, 0, 4);
    // The same bytes again: a duplicate (a resend), harmless.
    EXPECT_EQ(q.add_confirmed(1, input_of(1)), Add::Duplicate);
    EXPECT_EQ(q.add_confirmed(3, input_of(3)), Add::Duplicate);
    // Other bytes for a confirmed frame: the remote rewrote its past.
    EXPECT_EQ(q.add_confirmed(1, input_of(9)), Add::Conflict);
    EXPECT_EQ(q.add_confirmed(1, Bytes{0x01, 0x81}), Add::Conflict);  // one byte differs
    EXPECT_EQ(q.add_confirmed(1, Bytes{0x00, 0x80}), Add::Conflict);  // the other byte differs
    // Neither a duplicate nor a conflict changed anything.
    EXPECT_EQ(q.confirmed_count(), 4u);
    for (std::uint32_t f = 0; f < 4; ++f) EXPECT_EQ(bytes(q.confirmed(f)), input_of(f)) << "frame " << f;
    EXPECT_EQ(bytes(q.last_confirmed()), input_of(3));
}

TEST(InputQueue, AbsentFlagIsPartOfTheInput) {
    InputQueue q(2, 16);
    const Bytes neutral{0, 0};
    EXPECT_EQ(q.add_confirmed(0, neutral, true), Add::Stored);
    EXPECT_TRUE(q.confirmed_absent(0));
    EXPECT_TRUE(q.last_absent());
    EXPECT_EQ(q.add_confirmed(1, neutral, false), Add::Stored);  // the player joined
    EXPECT_FALSE(q.confirmed_absent(1));
    EXPECT_FALSE(q.last_absent());
    EXPECT_TRUE(q.confirmed_absent(0));  // the older flag is kept per frame
    // Equal bytes with the other flag is not a duplicate.
    EXPECT_EQ(q.add_confirmed(0, neutral, false), Add::Conflict);
    EXPECT_EQ(q.add_confirmed(1, neutral, true), Add::Conflict);
    EXPECT_EQ(q.add_confirmed(0, neutral, true), Add::Duplicate);
    EXPECT_EQ(q.add_confirmed(1, neutral, false), Add::Duplicate);
    EXPECT_TRUE(q.confirmed_absent(0));
    EXPECT_FALSE(q.confirmed_absent(1));
}

// Prediction vs confirmation: set_used() records what a simulation used, independently of what
// is later confirmed for the frame, so the caller can compare the two.
TEST(InputQueue, UsedInputIsKeptApartFromTheConfirmedOne) {
    InputQueue q(2, 8);
    const Bytes guess{7, 7};
    q.set_used(0, guess);                // frame 0 simulated with a guess...
    ASSERT_EQ(q.add_confirmed(0, input_of(0)), Add::Stored);  // ...then its real input arrives
    ASSERT_TRUE(q.used(0).has_value());
    EXPECT_EQ(bytes(*q.used(0)), guess);  // confirmation does not overwrite what was used
    EXPECT_EQ(bytes(q.confirmed(0)), input_of(0));
    EXPECT_FALSE(q.used_absent(0));
    // A resimulation with the confirmed input replaces the record.
    q.set_used(0, input_of(0));
    EXPECT_EQ(bytes(*q.used(0)), input_of(0));
    // Absent treatment is recorded per frame.
    q.set_used(1, Bytes{0, 0}, true);
    EXPECT_TRUE(q.used_absent(1));
    EXPECT_FALSE(q.used_absent(0));
    // Frames never simulated have no record, including ones sharing a slot with a recorded one.
    EXPECT_FALSE(q.used(2).has_value());
    EXPECT_FALSE(q.used(8).has_value());  // slot of frame 0
    EXPECT_FALSE(q.used(9).has_value());  // slot of frame 1
}

TEST(InputQueue, UsedRecordOfASlotBelongsToItsNewestFrame) {
    InputQueue q(2, 4);
    q.set_used(1, input_of(1));
    q.set_used(5, input_of(5));  // same slot, four frames later
    EXPECT_FALSE(q.used(1).has_value());
    ASSERT_TRUE(q.used(5).has_value());
    EXPECT_EQ(bytes(*q.used(5)), input_of(5));
}

TEST(InputQueue, CapacityIsCountedFromTheFloor) {
    InputQueue q(2, 8);
    confirm_range(q, 0, 8);  // floor 0: frames 0..7 fit
    EXPECT_EQ(q.add_confirmed(8, input_of(8)), Add::TooFarAhead);
    EXPECT_EQ(q.confirmed_count(), 8u);
    EXPECT_EQ(bytes(q.confirmed(0)), input_of(0));  // not overwritten by the refused frame 8
    q.discard_before(1);
    EXPECT_EQ(q.floor(), 1u);
    EXPECT_EQ(q.add_confirmed(8, input_of(8)), Add::Stored);
    EXPECT_EQ(q.add_confirmed(9, input_of(9)), Add::TooFarAhead);
}

TEST(InputQueue, RingWrapsAroundManyTimes) {
    InputQueue q(2, 8);
    // A long stream with the floor trailing 3 frames behind: every slot is reused ~60 times
    // and each read returns the frame asked for, never an older occupant of its slot.
    for (std::uint32_t f = 0; f < 500; ++f) {
        if (f >= 3) q.discard_before(f - 3);
        ASSERT_EQ(q.add_confirmed(f, input_of(f)), Add::Stored) << "frame " << f;
        for (std::uint32_t g = q.floor(); g <= f; ++g) ASSERT_EQ(bytes(q.confirmed(g)), input_of(g)) << g << " at " << f;
    }
    EXPECT_EQ(q.confirmed_count(), 500u);
    EXPECT_EQ(q.floor(), 496u);
    // Frames behind the floor are TooOld, whatever their bytes; held ones still compare.
    EXPECT_EQ(q.add_confirmed(495, input_of(495)), Add::TooOld);
    EXPECT_EQ(q.add_confirmed(488, input_of(496)), Add::TooOld);  // shares a slot with 496
    EXPECT_EQ(q.add_confirmed(496, input_of(496)), Add::Duplicate);
    EXPECT_EQ(q.add_confirmed(496, input_of(488)), Add::Conflict);
    // The ring is 8 frames from the floor: 500..503 fit, 504 does not.
    confirm_range(q, 500, 504);
    EXPECT_EQ(q.add_confirmed(504, input_of(504)), Add::TooFarAhead);
}

TEST(InputQueue, FloorNeverMovesBack) {
    InputQueue q(2, 8);
    confirm_range(q, 0, 6);
    q.discard_before(4);
    q.discard_before(2);
    q.discard_before(0);
    EXPECT_EQ(q.floor(), 4u);
    EXPECT_EQ(q.add_confirmed(3, input_of(3)), Add::TooOld);
    EXPECT_EQ(q.add_confirmed(4, input_of(4)), Add::Duplicate);
    // The floor may run ahead of the confirmed count (nothing below it will be read); the
    // next frame is still accepted.
    q.discard_before(10);
    EXPECT_EQ(q.floor(), 10u);
    EXPECT_EQ(q.add_confirmed(6, input_of(6)), Add::Stored);
}

TEST(InputQueue, LastConfirmedOutlivesItsSlot) {
    InputQueue q(2, 4);
    confirm_range(q, 0, 4);
    q.discard_before(4);  // every stored frame is behind the floor
    EXPECT_EQ(bytes(q.last_confirmed()), input_of(3));
    confirm_range(q, 4, 8);
    EXPECT_EQ(bytes(q.last_confirmed()), input_of(7));
}

// Datagram contents are not trusted: none of this may assert, throw or change the queue.
TEST(InputQueue, HostileNetworkInputIsRefusedWithoutHarm) {
    InputQueue q(3, 16);
    const Bytes good{1, 2, 3};
    ASSERT_EQ(q.add_confirmed(0, good), Add::Stored);
    ASSERT_EQ(q.add_confirmed(1, good), Add::Stored);
    const Bytes empty;
    const Bytes short_input{1, 2};
    const Bytes long_input{1, 2, 3, 4};
    const Bytes huge(4096, 0xAB);
    for (const std::uint32_t f : {0u, 1u, 2u, 3u, 1000u, std::numeric_limits<std::uint32_t>::max()}) {
        // Wrong-size input is a Conflict at any frame: past, next, future.
        EXPECT_EQ(q.add_confirmed(f, empty), Add::Conflict) << f;
        EXPECT_EQ(q.add_confirmed(f, short_input), Add::Conflict) << f;
        EXPECT_EQ(q.add_confirmed(f, long_input), Add::Conflict) << f;
        EXPECT_EQ(q.add_confirmed(f, huge), Add::Conflict) << f;
    }
    // Far future frames are gaps (dropped), including the largest frame number.
    EXPECT_EQ(q.add_confirmed(3, good), Add::Gap);
    EXPECT_EQ(q.add_confirmed(1u << 31, good), Add::Gap);
    EXPECT_EQ(q.add_confirmed(std::numeric_limits<std::uint32_t>::max(), good), Add::Gap);
    EXPECT_EQ(q.confirmed_count(), 2u);
    EXPECT_EQ(bytes(q.last_confirmed()), good);
    // The stream goes on where it was: nothing above was stored or overwritten.
    EXPECT_EQ(q.add_confirmed(2, good), Add::Stored);
    for (std::uint32_t f = 0; f < 3; ++f) EXPECT_EQ(bytes(q.confirmed(f)), good) << f;
}

TEST(InputQueue, HostileFarPastFramesAreTooOld) {
    InputQueue q(2, 16);
    for (std::uint32_t f = 0; f < 40; f += 8) {
        q.discard_before(f >= 8 ? f - 8 : 0);  // the floor trails, so 16 frames always fit
        confirm_range(q, f, f + 8);
    }
    q.discard_before(30);
    for (const std::uint32_t f : {0u, 1u, 13u, 14u, 29u}) {
        EXPECT_EQ(q.add_confirmed(f, input_of(f)), Add::TooOld) << f;
        EXPECT_EQ(q.add_confirmed(f, Bytes{0xFF, 0xFF}), Add::TooOld) << f;
    }
    EXPECT_EQ(q.add_confirmed(30, input_of(30)), Add::Duplicate);
    EXPECT_EQ(q.confirmed_count(), 40u);
    for (std::uint32_t f = 30; f < 40; ++f) EXPECT_EQ(bytes(q.confirmed(f)), input_of(f)) << f;
}

TEST(InputQueue, RestartBeginsANewStreamAtTheSnapshotFrame) {
    InputQueue q(2, 8);
    confirm_range(q, 0, 5);
    q.set_used(4, input_of(4));
    q.set_used(12, input_of(12));
    q.restart_at(12);
    EXPECT_EQ(q.confirmed_count(), 12u);
    EXPECT_EQ(q.floor(), 12u);
    EXPECT_TRUE(q.last_confirmed().empty());
    EXPECT_FALSE(q.last_absent());
    EXPECT_FALSE(q.used(4).has_value());   // nothing was simulated in the new stream
    EXPECT_FALSE(q.used(12).has_value());
    // Before the snapshot: too old; after its first frame: a gap; the snapshot frame: stored.
    EXPECT_EQ(q.add_confirmed(11, input_of(11)), Add::TooOld);
    EXPECT_EQ(q.add_confirmed(3, input_of(3)), Add::TooOld);
    EXPECT_EQ(q.add_confirmed(13, input_of(13)), Add::Gap);
    EXPECT_EQ(q.add_confirmed(12, input_of(12)), Add::Stored);
    EXPECT_EQ(bytes(q.last_confirmed()), input_of(12));
    // Capacity counts from the new floor.
    confirm_range(q, 13, 20);
    EXPECT_EQ(q.add_confirmed(20, input_of(20)), Add::TooFarAhead);
}

// What an input message resends (both sessions): the unacknowledged confirmed inputs from the
// ack (never below the floor), at most `max`.
TEST(InputQueue, CopyConfirmedGivesTheUnackedRun) {
    InputQueue q(2, 16);
    confirm_range(q, 0, 10);
    Bytes out{9, 9, 9};
    auto r = q.copy_confirmed(4, 3, out);
    EXPECT_EQ(r.first, 4u);
    EXPECT_EQ(r.count, 3u);
    ASSERT_EQ(out.size(), 6u);
    EXPECT_EQ(Bytes(out.begin(), out.begin() + 2), input_of(4));
    EXPECT_EQ(Bytes(out.begin() + 4, out.end()), input_of(6));
    r = q.copy_confirmed(8, 50, out);  // the rest only
    EXPECT_EQ(r.count, 2u);
    EXPECT_EQ(Bytes(out.begin() + 2, out.end()), input_of(9));
    q.discard_before(6);
    r = q.copy_confirmed(2, 50, out);  // an old ack starts at the floor
    EXPECT_EQ(r.first, 6u);
    EXPECT_EQ(r.count, 4u);
    r = q.copy_confirmed(10, 50, out);  // all acknowledged
    EXPECT_EQ(r.count, 0u);
    EXPECT_TRUE(out.empty());
    r = q.copy_confirmed(30, 50, out);  // an ack beyond what was sent copies nothing
    EXPECT_EQ(r.count, 0u);
}

}  // namespace
}  // namespace lockroll::rollback
