// Small parts on their own: input queue, snapshot ring, time sync, predictor, transfer ids and
// the transfer sender.
#include <gtest/gtest.h>

#include "rollback/input_queue.h"
#include "rollback/predictor.h"
#include "rollback/session_core.h"
#include "rollback/snapshot_ring.h"
#include "rollback/snapshot_transfer.h"
#include "rollback/time_sync.h"

namespace lockroll::rollback {
namespace {

std::vector<std::uint8_t> in(std::uint8_t v) { return {v, static_cast<std::uint8_t>(v + 1)}; }

TEST(InputQueue, AcceptsOnlyTheNextFrameAndNeverRewrites) {
    InputQueue q(2, 8);
    EXPECT_EQ(q.add_confirmed(1, in(1)), InputQueue::Add::Gap);
    EXPECT_EQ(q.add_confirmed(0, in(0)), InputQueue::Add::Stored);
    EXPECT_EQ(q.add_confirmed(1, in(1)), InputQueue::Add::Stored);
    EXPECT_EQ(q.confirmed_count(), 2u);
    EXPECT_EQ(q.add_confirmed(1, in(1)), InputQueue::Add::Duplicate);
    EXPECT_EQ(q.add_confirmed(1, in(7)), InputQueue::Add::Conflict);
    EXPECT_EQ(q.add_confirmed(2, std::vector<std::uint8_t>{1}), InputQueue::Add::Conflict);  // wrong size
    EXPECT_EQ(std::vector<std::uint8_t>(q.last_confirmed().begin(), q.last_confirmed().end()), in(1));
    // Capacity: with the floor at 0, frames 0..7 fit, frame 8 must wait.
    for (std::uint32_t f = 2; f < 8; ++f) EXPECT_EQ(q.add_confirmed(f, in(static_cast<std::uint8_t>(f))), InputQueue::Add::Stored);
    EXPECT_EQ(q.add_confirmed(8, in(8)), InputQueue::Add::TooFarAhead);
    q.discard_before(3);
    EXPECT_EQ(q.add_confirmed(8, in(8)), InputQueue::Add::Stored);
    EXPECT_EQ(q.add_confirmed(1, in(1)), InputQueue::Add::TooOld);
    EXPECT_EQ(std::vector<std::uint8_t>(q.confirmed(7).begin(), q.confirmed(7).end()), in(7));
    q.discard_before(2);  // never moves back
    EXPECT_EQ(q.floor(), 3u);
}

TEST(InputQueue, RemembersWhatEachFrameUsed) {
    InputQueue q(2, 4);
    EXPECT_FALSE(q.used(0).has_value());
    q.set_used(2, in(5));
    ASSERT_TRUE(q.used(2).has_value());
    EXPECT_EQ((*q.used(2))[0], 5);
    EXPECT_FALSE(q.used(6).has_value());  // same slot, other frame
    q.set_used(6, in(9));
    EXPECT_FALSE(q.used(2).has_value());
}

TEST(SnapshotRing, ForgetsOverwrittenFrames) {
    SnapshotRing ring(3, 4);
    for (std::uint32_t f = 0; f < 5; ++f) {
        auto s = ring.slot_for(f);
        std::fill(s.begin(), s.end(), static_cast<std::uint8_t>(f));
    }
    EXPECT_FALSE(ring.find(1).has_value());
    ASSERT_TRUE(ring.find(2).has_value());
    EXPECT_EQ((*ring.find(4))[3], 4);
    EXPECT_EQ((*ring.find(2))[0], 2);
    EXPECT_FALSE(ring.find(5).has_value());
    EXPECT_THROW(SnapshotRing(0, 4), std::invalid_argument);
}

TEST(TimeSync, RecommendsHalfTheGapOnceTheWindowIsFull) {
    TimeSync t(10);
    // We are 6 frames ahead: the peer seems 6 behind to us, we seem 6 ahead to it.
    for (int i = 0; i < 9; ++i) t.add_sample(-6, 6);
    EXPECT_EQ(t.recommended_wait(2), 0);  // not a full window yet
    t.add_sample(-6, 6);
    EXPECT_EQ(t.frames_ahead_x100(), 600);
    EXPECT_EQ(t.recommended_wait(2), 6);
    // Latency estimate errors cancel: both sides misjudge by +2.
    TimeSync u(4);
    for (int i = 0; i < 4; ++i) u.add_sample(-6 + 2, 6 + 2);
    EXPECT_EQ(u.recommended_wait(2), 6);
    // Behind or barely ahead: no wait.
    TimeSync b(4);
    for (int i = 0; i < 4; ++i) b.add_sample(3, -3);
    EXPECT_EQ(b.recommended_wait(1), 0);
    TimeSync c(4);
    for (int i = 0; i < 4; ++i) c.add_sample(-1, 1);
    EXPECT_EQ(c.recommended_wait(2), 0);
    c.clear();
    EXPECT_EQ(c.samples(), 0);
}

TEST(Predictor, RepeatsLastConfirmedOrNeutral) {
    RepeatLastPredictor p;
    std::vector<std::uint8_t> out(2, 7);
    p.predict(1, 5, {}, 0, out);
    EXPECT_EQ(out, (std::vector<std::uint8_t>{0, 0}));
    const auto last = in(3);
    p.predict(1, 5, last, 4, out);
    EXPECT_EQ(out, last);
}

// Both sessions number their offers so: 0 asks for an offer and is never an id (the relay
// session's counter used to wrap onto it).
TEST(TransferIds, CountUpAndSkipZeroWhenTheyWrap) {
    EXPECT_EQ(next_transfer_id(1), 2u);
    EXPECT_EQ(next_transfer_id(UINT32_MAX - 1), UINT32_MAX);
    EXPECT_EQ(next_transfer_id(UINT32_MAX), 1u);
    EXPECT_NE(next_transfer_id(UINT32_MAX), 0u);
}

// The providing side both sessions share: one offer per peer, at most kMaxTransfers, expired by
// age (never by a caller's time stepping back: the relay session's unguarded subtraction expired
// every offer then), chunks cut from the blob, the offer describing the packed blob.
TEST(TransferSender, BoundsOffersAndServesTheirChunks) {
    TransferSender s(1000);
    TransferContents t;
    t.frame = 7;
    t.state.assign(kSnapshotChunkBytes + 10, 0xAB);
    t.streams.resize(2);
    const auto& a = s.offer(3, TransferReason::Join, t, 2, 100);
    EXPECT_EQ(a.offer.transfer_id, 1u);
    EXPECT_EQ(a.offer.frame, 7u);
    EXPECT_EQ(a.offer.reason, TransferReason::Join);
    EXPECT_EQ(a.offer.size, a.blob.size());
    EXPECT_EQ(a.offer.hash, transfer_hash(a.blob));
    TransferContents back;
    EXPECT_EQ(unpack_transfer(a.blob, t.state.size(), 2, 2, 64, back), "");
    EXPECT_EQ(back.state, t.state);
    // A new offer to the same peer replaces its last.
    s.offer(3, TransferReason::Recover, t, 2, 200);
    ASSERT_EQ(s.transfers().size(), 1u);
    EXPECT_EQ(s.find(1, 3), nullptr);
    const TransferSender::Transfer* b = s.find(2, 3);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(s.find(2, 4), nullptr);  // not theirs
    SnapshotChunkMessage c;
    ASSERT_TRUE(TransferSender::chunk(*b, 1, c));
    EXPECT_EQ(c.transfer_id, 2u);
    EXPECT_EQ(c.chunk, 1u);
    EXPECT_EQ(c.bytes.size(), b->blob.size() - kSnapshotChunkBytes);
    EXPECT_FALSE(TransferSender::chunk(*b, 2, c));
    // Time stepping back expires nothing; at most kMaxTransfers, the oldest going first.
    for (PlayerId p = 10; p < 10 + TransferSender::kMaxTransfers; ++p) s.offer(p, TransferReason::Spectate, t, 2, 50);
    EXPECT_EQ(s.transfers().size(), TransferSender::kMaxTransfers);
    EXPECT_EQ(s.find(2, 3), nullptr);
    EXPECT_NE(s.find(3, 10), nullptr);
    // Older than the lifetime when the next offer is made: gone.
    s.offer(20, TransferReason::Join, t, 2, 5000);
    EXPECT_EQ(s.transfers().size(), 1u);
    EXPECT_EQ(s.transfers()[0].peer, 20u);
}

// Both sessions' stall bookkeeping. The relay session subtracted unguarded: a caller whose time
// stepped back during a stall added about 2^64 microseconds of stall.
TEST(StallTracker, CountsTicksAndTimeAndNeverWraps) {
    SessionStats s;
    StallTracker t;
    EXPECT_FALSE(t.stepped(100, s));
    t.stalled(1000, s);
    t.stalled(1016, s);
    EXPECT_TRUE(t.stalled());
    EXPECT_TRUE(t.stepped(1050, s));
    EXPECT_EQ(s.stall_ticks, 2u);
    EXPECT_EQ(s.stall_time_us, 50u);
    EXPECT_FALSE(t.stalled());
    t.stalled(5000, s);
    EXPECT_TRUE(t.stepped(4000, s));  // time went back
    EXPECT_EQ(s.stall_time_us, 50u);
    EXPECT_EQ(s.stall_ticks, 3u);
}

}  // namespace
}  // namespace lockroll::rollback
