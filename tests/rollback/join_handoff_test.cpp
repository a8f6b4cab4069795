// JoinHandoff (rollback/join_handoff.h) on its own, over a Sync, hand-built links and a
// recording JoinEffects (no session, no network): who may be served a snapshot, which offer goes
// out, the handoff of a slot to a joiner, and the view an offer carries to the newcomer.
#include "rollback/join_handoff.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "tests/rollback/session_parts.h"

namespace lockroll::rollback {
namespace {

struct RecordingEffects final : JoinEffects {
    std::vector<std::pair<PlayerId, std::vector<std::uint8_t>>> sent;
    std::vector<std::string> malformed_why;
    std::vector<PlayerId> desynced_peers;
    std::uint32_t target = 10;
    std::vector<std::pair<PlayerId, std::uint32_t>> joins;  // slot, handoff
    std::vector<PlayerId> spectators;
    int acks = 0;
    void send(PlayerId to, std::vector<std::uint8_t> bytes) override { sent.emplace_back(to, std::move(bytes)); }
    void malformed(PlayerId, const char* why) override { malformed_why.emplace_back(why); }
    bool desynced(PlayerId peer) const override {
        return std::find(desynced_peers.begin(), desynced_peers.end(), peer) != desynced_peers.end();
    }
    std::uint32_t handoff_target(PlayerId) const override { return target; }
    void joined(PlayerId slot, std::uint32_t handoff, std::uint32_t, std::uint64_t) override {
        joins.emplace_back(slot, handoff);
    }
    void spectator_joined(PlayerId peer, std::uint32_t, std::uint64_t) override { spectators.push_back(peer); }
    void acked() override { ++acks; }
    // The offer sent last (to `to`).
    SnapshotOfferMessage offer_to(PlayerId to) const {
        SnapshotOfferMessage m;
        EXPECT_FALSE(sent.empty());
        if (sent.empty()) return m;
        EXPECT_EQ(sent.back().first, to);
        EXPECT_EQ(decode(sent.back().second, m), nullptr);
        return m;
    }
};

SnapshotRequestMessage asks(TransferReason reason) {
    SnapshotRequestMessage m;
    m.reason = reason;
    return m;
}

// Three players (this session is slot 0) and one spectator peer (3); slot 2 dropped, its neutral
// input written by us.
struct Fixture : testing::SessionParts {
    SnapshotServer server;
    std::vector<int> replies = std::vector<int>(4, 0);
    RecordingEffects fx;
    bool running = true;

    Fixture() {
        config.max_recoveries = 3;
        membership.set(2, SlotState::Disconnected, 1);
        slots[2].authoring = true;
    }
    void request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us = 1000) {
        const JoinState s{config, membership, sync, server, links, slots, stats.peers, replies, running};
        JoinHandoff(s, fx).request(from, m, now_us);
    }
};

TEST(JoinHandoff, ARecoveryOnlyToARunningPlayerSeenDesynced) {
    Fixture f;
    f.request(1, asks(TransferReason::Recover));
    EXPECT_TRUE(f.fx.sent.empty());
    EXPECT_EQ(f.stats.peers[1].ignored_packets, 1u);
    f.request(3, asks(TransferReason::Recover));  // a spectator: no slot to recover
    EXPECT_EQ(f.stats.peers[3].ignored_packets, 1u);
    f.fx.desynced_peers = {1, 2};
    f.request(2, asks(TransferReason::Recover));  // beyond the view
    EXPECT_EQ(f.stats.peers[2].ignored_packets, 1u);
    EXPECT_TRUE(f.fx.sent.empty());
    f.request(1, asks(TransferReason::Recover));
    const SnapshotOfferMessage o = f.fx.offer_to(1);
    EXPECT_EQ(o.reason, TransferReason::Recover);
    EXPECT_EQ(o.handoff_frame, 0u);
    EXPECT_EQ(f.links[1].pin_from, 0u);
}

TEST(JoinHandoff, NoRecoveryWhenRecoveriesAreOff) {
    Fixture f;
    f.config.max_recoveries = 0;
    f.fx.desynced_peers = {1};
    f.request(1, asks(TransferReason::Recover));
    EXPECT_TRUE(f.fx.sent.empty());
    EXPECT_EQ(f.stats.peers[1].ignored_packets, 1u);
}

TEST(JoinHandoff, OnlyARunningPlayerServes) {
    Fixture f;
    f.running = false;
    f.request(3, asks(TransferReason::Spectate));
    f.request(2, asks(TransferReason::Join));
    EXPECT_TRUE(f.fx.sent.empty());
    f.running = true;
    f.config.role = Role::Spectator;
    f.request(3, asks(TransferReason::Spectate));
    EXPECT_TRUE(f.fx.sent.empty());
}

TEST(JoinHandoff, AJoinFromASlotWhoseDropWeDoNotOwnIsRefused) {
    Fixture f;
    f.slots[2].authoring = false;  // another player writes its neutral input
    f.request(2, asks(TransferReason::Join));
    EXPECT_TRUE(f.fx.sent.empty());
    EXPECT_TRUE(f.fx.joins.empty());
    EXPECT_FALSE(f.membership.running(2));
    f.request(1, asks(TransferReason::Join));  // a running slot
    EXPECT_TRUE(f.fx.sent.empty());
    f.request(3, asks(TransferReason::Join));  // not a slot
    EXPECT_TRUE(f.fx.sent.empty());
}

TEST(JoinHandoff, ALapsedHandoffIsNotRepeatedBeforeItsBackoff) {
    Fixture f;
    f.slots[2].next_handoff_us = 5000;
    f.request(2, asks(TransferReason::Join), 4999);
    EXPECT_TRUE(f.fx.sent.empty());
    f.request(2, asks(TransferReason::Join), 5000);
    EXPECT_EQ(f.fx.joins.size(), 1u);
}

TEST(JoinHandoff, TheOwnerHandsTheSlotOverAtTheHandoffFrame) {
    Fixture f;
    f.fx.target = 7;
    f.request(2, asks(TransferReason::Join));
    ASSERT_EQ(f.fx.joins.size(), 1u);
    EXPECT_EQ(f.fx.joins[0], std::make_pair(PlayerId{2}, std::uint32_t{7}));
    // Its neutral input up to the handoff, flagged absent; then its own.
    EXPECT_EQ(f.sync.queue(2).confirmed_count(), 7u);
    EXPECT_TRUE(f.sync.queue(2).confirmed_absent(6));
    EXPECT_TRUE(f.membership.running(2));
    EXPECT_EQ(f.membership.epoch(2), 2);
    EXPECT_EQ(f.slots[2].handoff, 7u);
    EXPECT_TRUE(f.slots[2].handed_off_by_me);
    EXPECT_TRUE(f.links[2].welcomed);
    const SnapshotOfferMessage o = f.fx.offer_to(2);
    EXPECT_EQ(o.reason, TransferReason::Join);
    EXPECT_EQ(o.handoff_frame, 7u);
    ASSERT_EQ(o.slots.size(), 3u);
    EXPECT_EQ(o.slots[2].state, SlotState::Running);
    EXPECT_EQ(o.slots[2].epoch, 2);
    EXPECT_EQ(f.fx.acks, 1);
}

TEST(JoinHandoff, AYoungOfferGoesAgainAsItWas) {
    Fixture f;
    f.request(2, asks(TransferReason::Join));
    const std::uint32_t id = f.fx.offer_to(2).transfer_id;
    f.request(2, asks(TransferReason::Join), 2000);  // the slot runs now: only the repeat answers
    ASSERT_EQ(f.fx.sent.size(), 2u);
    EXPECT_EQ(f.fx.offer_to(2).transfer_id, id);
    EXPECT_EQ(f.fx.joins.size(), 1u);
}

// Issue 21: slot 1 leaves while our handoff of slot 2 is pending. The joiner asks again: the
// young offer names slot 1 running, so it is not repeated; we serve the same handoff again (the
// same epoch and handoff frame, no second `joined`) with our view as it is now.
TEST(JoinHandoff, TheMakerReservesItsPendingHandoffWithTheCurrentTable) {
    Fixture f;
    f.fx.target = 7;
    f.request(2, asks(TransferReason::Join));
    const SnapshotOfferMessage first = f.fx.offer_to(2);
    f.membership.leave(1);
    f.request(2, asks(TransferReason::Join), 2000);
    ASSERT_EQ(f.fx.sent.size(), 2u);
    const SnapshotOfferMessage again = f.fx.offer_to(2);
    EXPECT_NE(again.transfer_id, first.transfer_id);
    EXPECT_EQ(again.handoff_frame, 7u);
    EXPECT_LE(again.frame, 7u);
    ASSERT_EQ(again.slots.size(), 3u);
    EXPECT_EQ(again.slots[1].state, SlotState::Disconnected);
    EXPECT_EQ(again.slots[2].state, SlotState::Running);
    EXPECT_EQ(again.slots[2].epoch, 2);
    EXPECT_EQ(f.membership.epoch(2), 2);
    EXPECT_EQ(f.sync.queue(2).confirmed_count(), 7u) << "no neutral input written past the handoff";
    EXPECT_EQ(f.fx.joins.size(), 1u);
    // Once we vote it gone (a lapse, a kick), it is not served again.
    f.membership.vote_local(2, true);
    f.request(2, asks(TransferReason::Join), 5'000'000);
    EXPECT_EQ(f.fx.sent.size(), 2u);
}

// Only the maker serves a pending handoff: a player that learned of it from a table has neither
// the handoff frame nor the neutral input up to it.
TEST(JoinHandoff, APendingHandoffWeDidNotMakeIsNotServed) {
    Fixture f;
    f.slots[2].authoring = false;
    f.membership.hand_over(2, 2);
    f.request(2, asks(TransferReason::Join));
    EXPECT_TRUE(f.fx.sent.empty());
    EXPECT_TRUE(f.fx.joins.empty());
}

TEST(JoinHandoff, ASpectatorStartsOnlyFromAPeerThatIsNotASlot) {
    Fixture f;
    f.request(1, asks(TransferReason::Spectate));
    EXPECT_TRUE(f.fx.sent.empty());
    f.request(3, asks(TransferReason::Spectate));
    EXPECT_EQ(f.fx.spectators, std::vector<PlayerId>{3});
    EXPECT_EQ(f.fx.offer_to(3).reason, TransferReason::Spectate);
}

TEST(JoinHandoff, ChunksOnlyOfThePeersOwnTransferAndAtMostSoManyPerPoll) {
    Fixture f;
    f.request(3, asks(TransferReason::Spectate));
    const SnapshotOfferMessage o = f.fx.offer_to(3);
    SnapshotRequestMessage c;
    c.reason = TransferReason::Spectate;
    c.transfer_id = o.transfer_id;
    f.request(1, c);  // not 1's transfer
    EXPECT_EQ(f.stats.peers[1].ignored_packets, 1u);
    c.chunk = static_cast<std::uint32_t>((o.size + kSnapshotChunkBytes - 1) / kSnapshotChunkBytes);  // past the blob
    f.request(3, c);
    ASSERT_EQ(f.fx.malformed_why.size(), 1u);
    c.chunk = 0;
    const std::size_t before = f.fx.sent.size();
    for (int i = 0; i < kMaxChunksPerPoll + 1; ++i) f.request(3, c);
    EXPECT_EQ(f.fx.sent.size(), before + kMaxChunksPerPoll);
    EXPECT_EQ(f.stats.peers[3].ignored_packets, 1u);
}

TEST(JoinHandoff, TheLoadedOffersTableBecomesTheView) {
    Fixture f;
    SnapshotOfferMessage o;
    o.slots = {{0, SlotState::Running, 3, 0}, {1, SlotState::Disconnected, 4, 0}, {2, SlotState::Running, 2, 0}};
    f.slots[0].handed_off_by_me = true;
    f.links[1].welcomed = true;
    f.links[2].interrupted = true;
    JoinHandoff::take_view(o, f.membership, f.slots, f.links, 9000);
    EXPECT_EQ(f.membership.epoch(0), 3);
    EXPECT_FALSE(f.membership.running(1));
    EXPECT_TRUE(f.membership.running(2));
    EXPECT_FALSE(f.slots[0].handed_off_by_me);
    EXPECT_TRUE(f.slots[1].neutral_reported);
    EXPECT_FALSE(f.slots[2].neutral_reported);
    EXPECT_TRUE(f.links[1].heard);
    EXPECT_FALSE(f.links[2].heard);
    EXPECT_FALSE(f.links[2].interrupted);
    EXPECT_EQ(f.links[2].last_heard_us, 9000u);
}

}  // namespace
}  // namespace lockroll::rollback
