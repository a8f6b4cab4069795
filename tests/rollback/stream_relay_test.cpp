// StreamRelay (rollback/stream_relay.h) on its own, over hand-built streams and links (no
// session, no network): what the slot table tells whom, when it rides, and which streams are
// relayed to a peer.
#include "rollback/stream_relay.h"

#include <gtest/gtest.h>

#include <vector>

#include "rollback/input_authority.h"
#include "tests/rollback/peer_links.h"

namespace lockroll::rollback {
namespace {

// Three players (this session is slot 0) and one spectator (peer 3).
struct Fixture {
    SessionConfig config;
    Membership membership{3, 0, TwoPlayerRule::PlayOnAlone};
    std::vector<InputQueue> queues;
    InputAuthority authority{3, 4};
    std::vector<SlotView> slots{3};
    std::vector<PeerLink> links = testing::fresh_links(4);  // the three players' and the spectator's
    std::uint32_t confirmed = 0;  // the session's confirmed frame

    Fixture() {
        config.players = 3;
        config.max_spectators = 1;
        config.input_size = 1;
        config.relay_lag = 4;
        config.prediction_window = 8;
        for (int s = 0; s < 3; ++s) queues.emplace_back(1, 64);
    }
    void fill(PlayerId slot, std::uint32_t frames) {
        for (std::uint32_t f = queues[slot].confirmed_count(); f < frames; ++f) {
            const std::uint8_t b = static_cast<std::uint8_t>(f);
            queues[slot].add_confirmed(f, std::span(&b, 1));
        }
    }
    // Peer `to` reported holding `count` of slot's stream at `at_us`.
    void counts(PlayerId to, PlayerId slot, std::uint32_t count, std::uint64_t at_us) {
        links[to].counts[slot] = count;
        links[to].has_count[slot] = true;
        links[to].counts_at_us = at_us;
    }
    StreamRelay relay() const { return StreamRelay({config, membership, queues, authority, slots, links, confirmed, 0, false}); }
    std::vector<StreamBlock> blocks_to(PlayerId to, std::uint64_t now_us, std::size_t budget = 1000) const {
        InputMessage m;
        relay().fill_extension(to, m, budget, now_us);
        EXPECT_EQ(m.slots.size(), 3u);
        return m.blocks;
    }
};

TEST(StreamRelay, TableTellsAPlayerOurVoteAndASpectatorTheView) {
    Fixture f;
    f.membership.vote_local(2, true);
    const SlotEntry to_player = f.relay().table_entry(1, 2);
    EXPECT_EQ(to_player.state, SlotState::Disconnected);
    EXPECT_EQ(to_player.epoch, 1);
    const SlotEntry to_spectator = f.relay().table_entry(3, 2);
    EXPECT_EQ(to_spectator.state, SlotState::Running);
    EXPECT_EQ(to_spectator.epoch, 0);
}

TEST(StreamRelay, TableRidesOnlyWhenItChangedOnceEverySlotRuns) {
    Fixture f;
    std::vector<std::uint16_t> entries;
    f.relay().table_entries_for(1, entries);
    f.links[1].table_assumed(entries, 0);
    f.links[1].messages_sent = 1;  // not a time-sync message
    EXPECT_FALSE(f.relay().extension_needed(1, entries, 0, false));
    EXPECT_TRUE(f.relay().extension_needed(3, entries, 0, false)) << "a spectator always gets the table";
    f.membership.vote_local(2, true);
    f.relay().table_entries_for(1, entries);
    EXPECT_TRUE(f.relay().extension_needed(1, entries, 0, false)) << "our vote must reach the voters";
}

TEST(StreamRelay, RelaysAStreamOnlyToAPeerWhoseFreshCountsLagBeyondRelayLag) {
    Fixture f;
    f.fill(2, 20);
    const std::uint64_t now = 10'000'000;
    f.counts(1, 2, 5, now);
    const auto blocks = f.blocks_to(1, now);
    ASSERT_EQ(blocks.size(), 1u);
    EXPECT_EQ(blocks[0].slot, 2);
    EXPECT_EQ(blocks[0].first_frame, 5);
    EXPECT_EQ(blocks[0].frame_count, 15);
    f.counts(1, 2, 5, now - 2'000'000);
    EXPECT_TRUE(f.blocks_to(1, now).empty()) << "counts of seconds ago are no lag";
    f.counts(1, 2, 16, now);
    EXPECT_TRUE(f.blocks_to(1, now).empty()) << "within relay_lag the owner's own stream will do";
}

TEST(StreamRelay, NeverRelaysTheReceiversOwnStreamNorAnotherRelaysClaim) {
    Fixture f;
    f.fill(1, 20);
    f.fill(2, 20);
    const std::uint64_t now = 10'000'000;
    f.counts(1, 1, 0, now);
    f.counts(1, 2, 5, now);
    f.authority.note_relayed(2, 12, 1);  // frame 12 of slot 2 came from a relay, unverified
    const auto blocks = f.blocks_to(1, now);
    ASSERT_EQ(blocks.size(), 1u);
    EXPECT_EQ(blocks[0].slot, 2);
    EXPECT_EQ(blocks[0].frame_count, 7) << "up to the first unverified input only";
}

// What we tell an owner we hold of its stream stops at the first relayed input it has not
// verified, even once confirmed (trust, then verify: its resends then expose a lie), but no
// further back than a quarter of the input ring behind confirmation.
TEST(StreamRelay, TheOwnersCountStopsAtAnUnverifiedRelayedInputEvenConfirmed) {
    Fixture f;
    f.config.input_capacity = 64;  // reach: 16 frames behind confirmation
    f.fill(2, 40);
    f.authority.note_relayed(2, 20, 1);
    f.confirmed = 10;
    EXPECT_EQ(f.relay().owner_count(2), 20u);
    EXPECT_EQ(f.relay().table_entry(2, 2).count, 20u) << "the owner's table entry says the same";
    EXPECT_EQ(f.relay().table_entry(1, 2).count, 40u) << "anyone else gets our whole count";
    f.confirmed = 30;  // confirmed past it, on the relay's word
    EXPECT_EQ(f.relay().owner_count(2), 20u);
    f.confirmed = 37;  // more than 16 frames behind: left to the checksums
    EXPECT_EQ(f.relay().owner_count(2), 40u);
    f.confirmed = 30;
    f.authority.verified(2, 20);
    EXPECT_EQ(f.relay().owner_count(2), 40u);
}

TEST(StreamRelay, BlocksShrinkToFitTheBudget) {
    Fixture f;
    f.fill(2, 40);
    const std::uint64_t now = 10'000'000;
    f.counts(1, 2, 0, now);
    const std::size_t table = 2 + 3 * 5;
    const auto whole = f.blocks_to(1, now);
    ASSERT_EQ(whole.size(), 1u);
    EXPECT_EQ(whole[0].frame_count, 40);
    const auto cut = f.blocks_to(1, now, table + encoded_block_bytes(whole[0], 1) - 1);
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].frame_count, 20);
}

TEST(StreamRelay, LagsOnAStreamOnlyByMoreThanHalfTheRelayLag) {
    Fixture f;
    f.fill(0, 20);
    f.fill(1, 19);
    f.fill(2, 19);
    EXPECT_FALSE(f.relay().lags_on_a_stream());
    f.fill(0, 21);
    EXPECT_TRUE(f.relay().lags_on_a_stream()) << "relay_lag 4: a lag of 2 asks for relays";
}

}  // namespace
}  // namespace lockroll::rollback
