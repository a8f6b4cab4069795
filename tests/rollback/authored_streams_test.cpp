// AuthoredStreams (rollback/authored_streams.h) on its own, over hand-built streams, view and
// links (no session, no network): only the owner writes a dropped slot's neutral input, and only
// once every live player peer reported the drop holding no more of its stream than we do; a
// host's guests follow its own stream frame for frame.
#include "rollback/authored_streams.h"

#include <gtest/gtest.h>

#include <vector>

#include "tests/rollback/fake_effects.h"

namespace lockroll::rollback {
namespace {

using Kind = SessionEvent::Kind;
using testing::EffectsFixture;

// `players` slots, this session `local`, no spectator.
struct Fixture : EffectsFixture {
    AuthoredStreams authored;

    Fixture(int players, PlayerId local, std::vector<PlayerId> hosts = {})
        : EffectsFixture(players, local, std::move(hosts), TwoPlayerRule::PlayOnAlone, 0),
          authored(config, view, slots, links, fake) {}
    void fill(PlayerId slot, std::uint32_t frames, std::uint8_t value) {
        for (std::uint32_t f = fake.queues[slot].confirmed_count(); f < frames; ++f)
            fake.queues[slot].add_confirmed(f, std::span(&value, 1));
    }
    // Peer p's table reports `slot` as our view has it, holding `count` of its stream.
    void reports(PlayerId p, PlayerId slot, std::uint32_t count) {
        links[p].table[slot] = {static_cast<std::uint8_t>(slot), view.state(slot), view.epoch(slot), 0};
        links[p].table_seen[slot] = true;
        links[p].counts[slot] = count;
        links[p].has_count[slot] = true;
    }
    std::uint32_t count(PlayerId slot) const { return fake.queues[slot].confirmed_count(); }
};

TEST(AuthoredStreams, TheOwnerWaitsForEveryPlayersReportThenWritesNeutralFromThere) {
    Fixture f(4, 0);
    f.fill(3, 5, 9);
    f.view.leave(3);
    f.authored.author_absent_streams(20, 100);
    EXPECT_EQ(f.count(3), 5u) << "nobody reported the drop yet";
    f.reports(1, 3, 5);
    f.reports(2, 3, 6);  // holds more than we do: we get it relayed first
    f.authored.author_absent_streams(20, 100);
    EXPECT_EQ(f.count(3), 5u);
    EXPECT_TRUE(f.fake.of(Kind::NeutralFrom).empty());
    f.fill(3, 6, 9);  // the relayed input arrived
    f.authored.author_absent_streams(20, 100);
    EXPECT_EQ(f.count(3), 21u) << "neutral up to the target, inclusive";
    EXPECT_TRUE(f.fake.queues[3].confirmed_absent(6));
    EXPECT_TRUE(f.fake.queues[3].confirmed_absent(20));
    EXPECT_FALSE(f.fake.queues[3].confirmed_absent(5));
    const auto neutral_from = f.fake.of(Kind::NeutralFrom);
    ASSERT_EQ(neutral_from.size(), 1u);
    EXPECT_EQ(neutral_from[0].peer, PlayerId{3});
    EXPECT_EQ(neutral_from[0].frame, 6u);
    EXPECT_EQ(neutral_from[0].reason, SessionEvent::Reason::WritesNeutral);

    // Authoring once begun goes on without asking again, and the frame is told once per epoch.
    f.links[1].table_seen[3] = false;
    f.authored.author_absent_streams(25, 200);
    EXPECT_EQ(f.count(3), 26u);
    EXPECT_EQ(f.fake.of(Kind::NeutralFrom).size(), 1u);
}

TEST(AuthoredStreams, ATableInAnotherEpochIsNoReportOfTheDrop) {
    Fixture f(3, 0);
    f.view.leave(2);
    f.reports(1, 2, 0);
    f.links[1].table[2].epoch = 0;  // it still has slot 2 running in its old epoch
    f.links[1].table[2].state = SlotState::Running;
    f.authored.author_absent_streams(10, 100);
    EXPECT_EQ(f.count(2), 0u);
}

// A peer's vote is written as the drop it wants ("disconnected" in the next epoch, flagged
// voted): same epoch and state as our drop, but the slot still runs there and its process's
// inputs still come in, so the count beside the vote still grows (a kick or a lapse, whose
// process lives). Taken for the drop applied, the owner began the neutral input below inputs
// that peer then confirmed (Lifecycle.KickOfALivePlayerOfThree...: desync). Only the drop
// applied counts.
TEST(AuthoredStreams, APeersVoteIsNoReportOfTheDrop) {
    Fixture f(3, 0);
    f.fill(2, 5, 9);
    f.view.leave(2);
    f.reports(1, 2, 5);
    f.links[1].table[2].voted = true;
    f.authored.author_absent_streams(10, 100);
    EXPECT_EQ(f.count(2), 5u) << "only voted: its count may still grow";
    EXPECT_TRUE(f.fake.of(Kind::NeutralFrom).empty());
    f.links[1].table[2].voted = false;  // it applied the drop: its count is final
    f.authored.author_absent_streams(10, 100);
    EXPECT_EQ(f.count(2), 11u);
    ASSERT_EQ(f.fake.of(Kind::NeutralFrom).size(), 1u);
    EXPECT_EQ(f.fake.of(Kind::NeutralFrom)[0].frame, 5u);
}

TEST(AuthoredStreams, OnlyTheLowestRunningSlotWritesAndNeverASpectator) {
    Fixture f(3, 1);
    f.view.leave(2);
    f.reports(0, 2, 0);
    EXPECT_EQ(f.authored.owner(), PlayerId{0});
    f.authored.author_absent_streams(10, 100);
    EXPECT_EQ(f.count(2), 0u) << "slot 0 owns";
    f.view.leave(0);
    f.reports(0, 0, 0);
    EXPECT_EQ(f.authored.owner(), PlayerId{1});
    f.authored.author_absent_streams(10, 100);
    EXPECT_EQ(f.count(0), 11u);
    EXPECT_EQ(f.count(2), 11u);

    Fixture spectator(2, 0);
    spectator.config.role = Role::Spectator;
    spectator.view.leave(1);
    spectator.authored.author_absent_streams(10, 100);
    EXPECT_EQ(spectator.count(1), 0u);
}

TEST(AuthoredStreams, GuestsFollowTheLocalStreamRepeatingTheirLastInputInTheGap) {
    Fixture f(3, 0, {0, 0, 2});  // this process plays slots 0 and 1
    const std::vector<PlayerId> local_slots{0, 1};
    const auto guest = [&] {
        std::vector<int> out;
        for (std::uint32_t fr = 0; fr < f.count(1); ++fr) out.push_back(f.fake.queues[1].confirmed(fr)[0]);
        return out;
    };
    f.fill(0, 3, 5);
    f.authored.author_guest_streams(local_slots, std::vector<std::uint8_t>{7});
    EXPECT_EQ(guest(), (std::vector<int>{0, 0, 7})) << "neutral before its first input, the newest frame takes it";
    f.fill(0, 5, 5);
    f.authored.author_guest_streams(local_slots, std::vector<std::uint8_t>{9});
    EXPECT_EQ(guest(), (std::vector<int>{0, 0, 7, 7, 9})) << "the gap repeats its last input";
    EXPECT_FALSE(f.fake.queues[1].confirmed_absent(4));

    f.view.leave(1);
    f.fill(0, 8, 5);
    f.authored.author_guest_streams(local_slots, std::vector<std::uint8_t>{9});
    EXPECT_EQ(f.count(1), 5u) << "a guest that does not run is not written";
}

}  // namespace
}  // namespace lockroll::rollback
