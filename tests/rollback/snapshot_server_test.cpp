// SnapshotServer (rollback/snapshot_server.h) on its own: what a request for an offer costs the
// provider (the young offer again, a recovery packed at most once a second), chunks only of a
// peer's own transfer, and the fault injection on sent chunks.
#include "rollback/snapshot_server.h"

#include <gtest/gtest.h>

#include <vector>

namespace lockroll::rollback {
namespace {

TransferContents contents() {
    TransferContents t;
    t.frame = 5;
    t.state.assign(1500, 3);  // two chunks
    t.streams.resize(2);
    return t;
}

// A server that offered contents() to peer 1, and peer 1's request for that transfer's chunk 0.
struct Offered {
    SnapshotServer s;
    SnapshotRequestMessage r;
    Offered() { r.transfer_id = s.offer(1, TransferReason::Join, contents(), 1, 0).offer.transfer_id; }
};

TEST(SnapshotServer, RepeatsAYoungOfferAndPacksAgainOnceItAged) {
    SnapshotServer s;
    const SnapshotOfferMessage* repeat = nullptr;
    EXPECT_EQ(s.consider(1, TransferReason::Join, 0, {}, &repeat), SnapshotServer::Ask::Pack);
    const std::uint32_t id = s.offer(1, TransferReason::Join, contents(), 1, 0).offer.transfer_id;
    ASSERT_EQ(s.consider(1, TransferReason::Join, 1'999'999, {}, &repeat), SnapshotServer::Ask::Repeat);
    EXPECT_EQ(repeat->transfer_id, id);
    EXPECT_EQ(s.consider(2, TransferReason::Join, 1'000, {}, &repeat), SnapshotServer::Ask::Pack) << "another peer";
    EXPECT_EQ(s.consider(1, TransferReason::Spectate, 1'000, {}, &repeat), SnapshotServer::Ask::Pack) << "another reason";
    EXPECT_EQ(s.consider(1, TransferReason::Join, 2'000'000, {}, &repeat), SnapshotServer::Ask::Pack);
}

// Issue 21: the newcomer vets a snapshot against the view its offer names; once a slot has left
// the provider's view, the young offer's table is stale, and the request is packed afresh.
TEST(SnapshotServer, AYoungOfferIsPackedAgainOnceTheViewChanged) {
    SnapshotServer s;
    const SnapshotOfferMessage* repeat = nullptr;
    const std::vector<SlotEntry> before{{0, SlotState::Running, 0, 0}, {1, SlotState::Running, 2, 0},
                                        {2, SlotState::Running, 0, 0}};
    std::vector<SlotEntry> after = before;
    after[2] = {2, SlotState::Disconnected, 1, 0};
    s.offer(1, TransferReason::Join, contents(), 1, 0).offer.slots = before;
    EXPECT_EQ(s.consider(1, TransferReason::Join, 1'000, before, &repeat), SnapshotServer::Ask::Repeat);
    EXPECT_EQ(s.consider(1, TransferReason::Join, 1'000, after, &repeat), SnapshotServer::Ask::Pack);
    after = before;
    after[1].count = 7;  // counts and votes are no part of the view
    after[1].voted = true;
    EXPECT_EQ(s.consider(1, TransferReason::Join, 1'000, after, &repeat), SnapshotServer::Ask::Repeat);
}

TEST(SnapshotServer, PacksARecoveryAtMostOnceASecond) {
    SnapshotServer s;
    const SnapshotOfferMessage* repeat = nullptr;
    s.offer(1, TransferReason::Recover, contents(), 1, 0);
    EXPECT_EQ(s.consider(1, TransferReason::Recover, 299'999, {}, &repeat), SnapshotServer::Ask::Repeat);
    EXPECT_EQ(s.consider(1, TransferReason::Recover, 300'000, {}, &repeat), SnapshotServer::Ask::TooSoon);
    EXPECT_EQ(s.consider(1, TransferReason::Recover, SnapshotServer::kRecoveryIntervalUs - 1, {}, &repeat),
              SnapshotServer::Ask::TooSoon);
    EXPECT_EQ(s.consider(1, TransferReason::Recover, SnapshotServer::kRecoveryIntervalUs, {}, &repeat),
              SnapshotServer::Ask::Pack);
}

TEST(SnapshotServer, ServesChunksOnlyOfThePeersOwnTransfer) {
    Offered x;
    SnapshotChunkMessage c;
    EXPECT_EQ(x.s.chunk(1, x.r, c), SnapshotServer::Chunk::Ready);
    EXPECT_EQ(x.s.chunk(2, x.r, c), SnapshotServer::Chunk::NotOurs);
    x.r.chunk = 1000;
    EXPECT_EQ(x.s.chunk(1, x.r, c), SnapshotServer::Chunk::OutOfRange);
}

TEST(SnapshotServer, DamagesTheNextChunksInOrderThenNoMore) {
    Offered x;
    SnapshotChunkMessage whole;
    ASSERT_EQ(x.s.chunk(1, x.r, whole), SnapshotServer::Chunk::Ready);
    x.s.damage(1, ChunkDamage::FlipBit);
    x.s.damage(1, ChunkDamage::Truncate);
    SnapshotChunkMessage c = whole;
    x.s.damage_next(c);
    EXPECT_EQ(c.bytes.size(), whole.bytes.size());
    EXPECT_NE(c.bytes, whole.bytes);
    c = whole;
    x.s.damage_next(c);
    EXPECT_EQ(c.bytes.size(), whole.bytes.size() - 1);
    c = whole;
    x.s.damage_next(c);
    EXPECT_EQ(c.bytes, whole.bytes) << "the count is used up";
    EXPECT_EQ(x.s.damaged_chunks(), 2u);
}

}  // namespace
}  // namespace lockroll::rollback
