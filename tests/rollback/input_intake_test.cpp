// InputIntake (rollback/input_intake.h) on its own, over a Sync, hand-built links and a
// recording IntakeEffects (no session, no network): what a peer's input message changes -- the
// sender's inputs, the owner's copy against a relay's, the table's counts and votes, relayed
// blocks that only fill gaps.
#include "rollback/input_intake.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "rollback/input_authority.h"
#include "tests/rollback/session_parts.h"

namespace lockroll::rollback {
namespace {

struct Vote3 {
    PlayerId voter, slot;
    Vote vote;
    std::uint8_t epoch;
};

struct RecordingEffects final : IntakeEffects {
    std::vector<std::string> malformed_why;
    std::vector<PlayerId> adopted;
    std::vector<Vote3> votes;
    int acks = 0, settles = 0;
    std::vector<std::pair<PlayerId, std::uint32_t>> neutral;
    std::vector<std::uint32_t> checksum_frames;
    void malformed(PlayerId, const char* why) override { malformed_why.emplace_back(why); }
    void acked() override { ++acks; }
    void adopt_slot(PlayerId slot, const SlotEntry&, std::uint64_t) override { adopted.push_back(slot); }
    void count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) override {
        votes.push_back({voter, slot, vote, epoch});
    }
    std::vector<AgreementReport> agreements;
    std::vector<Vote3> drops;  // voter, slot, Gone, epoch
    void heard_agreement(PlayerId, const AgreementReport& r) override { agreements.push_back(r); }
    void heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) override { drops.push_back({voter, slot, Vote::Gone, epoch}); }
    void settle_membership(std::uint64_t) override { ++settles; }
    void remote_checksum(PlayerId, std::uint32_t frame, std::uint64_t) override { checksum_frames.push_back(frame); }
    void neutral_from(PlayerId slot, std::uint32_t frame) override { neutral.emplace_back(slot, frame); }
    bool failed() const override { return false; }
};

using Bytes = std::vector<std::uint8_t>;
constexpr std::size_t kN = kWorldInputSize;

Bytes inputs(std::uint8_t v, int frames) { return Bytes(kN * static_cast<std::size_t>(frames), v); }

// Three players (this session is slot 0, or a spectator) and one spectator peer (3).
struct Fixture : testing::SessionParts {
    InputAuthority authority{3, 4};
    RecordingEffects fx;

    explicit Fixture(Role role = Role::Player) {
        config.role = role;
        if (role == Role::Spectator) config.local_player = 3;
    }
    void apply(PlayerId from, const InputMessage& m) {
        InputIntake(IntakeState{config, membership, sync, authority, links, slots, stats.peers, 0, 20}, fx)
            .apply(from, m, 1000);
    }
    // The owner's own inputs of its slot, frames [first, first + frames).
    static InputMessage own(std::uint16_t first, const Bytes& in) {
        InputMessage m;
        m.first_frame = first;
        m.frame_count = static_cast<std::uint8_t>(in.size() / kN);
        m.inputs = in;
        return m;
    }
    // A block of `slot`'s stream relayed by the sender.
    static InputMessage relayed(PlayerId slot, std::uint16_t first, const Bytes& in, bool absent = false) {
        InputMessage m;
        m.has_extension = true;
        StreamBlock b;
        b.slot = static_cast<std::uint8_t>(slot);
        b.absent = absent;
        b.first_frame = first;
        b.frame_count = static_cast<std::uint8_t>(in.size() / kN);
        b.inputs = in;
        m.blocks.push_back(b);
        return m;
    }
    std::uint8_t held(PlayerId slot, std::uint32_t f) const { return sync.queue(slot).confirmed(f)[0]; }
};

TEST(InputIntake, OwnInputsGoIntoSyncAndAnAckIsTaken) {
    Fixture f;
    InputMessage m = Fixture::own(0, inputs(7, 3));
    f.apply(1, m);
    EXPECT_TRUE(f.fx.malformed_why.empty());
    EXPECT_EQ(f.sync.queue(1).confirmed_count(), 3u);
    EXPECT_EQ(f.held(1, 2), 7);
    EXPECT_EQ(f.fx.acks, 0);  // ack 0: nothing new
}

TEST(InputIntake, AMessageThatDoesNotUnwrapChangesNothing) {
    Fixture f;
    InputMessage m = Fixture::own(0, inputs(7, 2));
    m.ack = 5;  // acknowledges inputs we never sent
    f.apply(1, m);
    ASSERT_EQ(f.fx.malformed_why.size(), 1u);
    EXPECT_EQ(f.fx.malformed_why[0], "input message: acknowledges inputs never sent");
    EXPECT_EQ(f.sync.queue(1).confirmed_count(), 0u);
}

TEST(InputIntake, AConfirmedInputRewriteIsMalformed) {
    Fixture f;
    f.apply(1, Fixture::own(0, inputs(7, 2)));
    f.apply(1, Fixture::own(1, inputs(8, 1)));  // frame 1 again, other bytes, nobody relayed it
    ASSERT_EQ(f.fx.malformed_why.size(), 1u);
    EXPECT_EQ(f.fx.malformed_why[0], "input message: rewrites a confirmed input");
    EXPECT_EQ(f.held(1, 1), 7);
}

TEST(InputIntake, ARelayedBlockThatDisagreesWithTheOwnersCopyIsCountedAndIgnored) {
    Fixture f;
    f.apply(1, Fixture::own(0, inputs(7, 2)));
    f.apply(2, Fixture::relayed(1, 0, inputs(9, 2)));  // 2 relays 1's stream, altered
    EXPECT_TRUE(f.fx.malformed_why.empty());           // never a protocol violation
    EXPECT_EQ(f.stats.peers[2].relay_disagreements, 1u);
    EXPECT_TRUE(f.authority.ignored(2));
    EXPECT_EQ(f.held(1, 0), 7);                         // the owner's copy stands
    // From then on its relayed blocks are ignored, honest ones too.
    f.apply(2, Fixture::relayed(1, 2, inputs(7, 1)));
    EXPECT_EQ(f.stats.peers[2].ignored_packets, 1u);
    EXPECT_EQ(f.sync.queue(1).confirmed_count(), 2u);
}

TEST(InputIntake, TheOwnersCopyReplacesARelayedInputItContradicts) {
    Fixture f;
    f.apply(2, Fixture::relayed(1, 0, inputs(9, 2)));  // fills the gap: a claim
    EXPECT_EQ(f.held(1, 0), 9);
    EXPECT_EQ(f.authority.relay_of(1, 0), PlayerId{2});
    f.apply(1, Fixture::own(0, inputs(7, 2)));         // the owner wins, and is not blamed
    EXPECT_TRUE(f.fx.malformed_why.empty());
    EXPECT_EQ(f.held(1, 0), 7);
    EXPECT_EQ(f.held(1, 1), 7);
    EXPECT_EQ(f.stats.peers[2].relay_disagreements, 2u);  // one per contradicted frame
    EXPECT_TRUE(f.authority.ignored(2));
}

TEST(InputIntake, AnEqualOwnersCopyVerifiesTheRelayedOne) {
    Fixture f;
    f.apply(2, Fixture::relayed(1, 0, inputs(7, 1)));
    ASSERT_TRUE(f.authority.first_unverified().has_value());
    f.apply(1, Fixture::own(0, inputs(7, 1)));
    EXPECT_FALSE(f.authority.first_unverified().has_value());
    EXPECT_EQ(f.stats.peers[2].relay_disagreements, 0u);
}

// Two relays' copies of a frame differ (here 3, a peer like any other to the intake, holds
// first): neither is blamed until the owner's copy verifies the held one, which counts the
// other; the owner and the honest relay are never blamed.
TEST(InputIntake, ARelayDisputingAClaimTheOwnerVerifiesIsCountedAndIgnored) {
    Fixture f;
    f.apply(3, Fixture::relayed(1, 0, inputs(7, 2)));
    f.apply(2, Fixture::relayed(1, 0, inputs(9, 2)));  // a claim against a claim
    EXPECT_EQ(f.held(1, 0), 7);
    EXPECT_EQ(f.stats.peers[2].relay_disagreements, 0u);
    f.apply(1, Fixture::own(0, inputs(7, 2)));
    EXPECT_TRUE(f.fx.malformed_why.empty());
    EXPECT_EQ(f.stats.peers[2].relay_disagreements, 1u);  // it disputed frame 0 (its block stopped there)
    EXPECT_TRUE(f.authority.ignored(2));
    EXPECT_EQ(f.stats.peers[3].relay_disagreements, 0u);
    EXPECT_EQ(f.stats.peers[1].relay_disagreements, 0u);
    EXPECT_FALSE(f.authority.first_unverified().has_value());
}

TEST(InputIntake, NobodyRelaysOurOwnStreamOrTheSendersToUs) {
    Fixture f;
    InputMessage m = Fixture::relayed(0, 0, inputs(9, 1));
    m.blocks.push_back(Fixture::relayed(2, 0, inputs(9, 1)).blocks[0]);
    f.apply(2, m);
    EXPECT_EQ(f.sync.queue(0).confirmed_count(), 0u);
    EXPECT_EQ(f.sync.queue(2).confirmed_count(), 0u);
}

TEST(InputIntake, ARelayedInputContradictingAConfirmedOneOfASlotBeyondTheViewIsMalformed) {
    Fixture f;
    f.membership.set(2, SlotState::Disconnected, 1);
    f.apply(1, Fixture::relayed(2, 0, inputs(0, 2), true));
    EXPECT_TRUE(f.fx.malformed_why.empty());
    ASSERT_EQ(f.fx.neutral.size(), 1u);  // the first absent input tells the agreed frame
    EXPECT_EQ(f.fx.neutral[0], std::make_pair(PlayerId{2}, std::uint32_t{0}));
    f.apply(1, Fixture::relayed(2, 1, inputs(4, 1)));
    ASSERT_EQ(f.fx.malformed_why.size(), 1u);
    EXPECT_EQ(f.fx.malformed_why[0], "input message: relayed input contradicts a confirmed one");
}

SlotEntry entry(PlayerId slot, SlotState state, std::uint8_t epoch, std::uint16_t count = 0) {
    return {static_cast<std::uint8_t>(slot), state, epoch, count};
}

TEST(InputIntake, APlayersTableVotesAboutOthersAndHandsOverInNewerEpochs) {
    Fixture f;
    InputMessage m;
    m.has_extension = true;
    m.slots = {entry(0, SlotState::Disconnected, 1),  // about us: a vote (we run), never an adoption
               entry(1, SlotState::Disconnected, 1),  // about itself: nothing new
               entry(2, SlotState::Running, 0)};      // our epoch, running: a vote that it runs
    f.apply(1, m);
    ASSERT_EQ(f.fx.votes.size(), 2u);
    EXPECT_EQ(f.fx.votes[0].slot, 0);
    EXPECT_EQ(f.fx.votes[0].vote, Vote::Gone);
    EXPECT_EQ(f.fx.votes[1].slot, 2);
    EXPECT_EQ(f.fx.votes[1].vote, Vote::Runs);
    EXPECT_TRUE(f.fx.adopted.empty());
    EXPECT_EQ(f.fx.settles, 1);
    // A newer epoch of a running slot, running: a hand-over to a new process.
    m.slots = {entry(2, SlotState::Running, 1)};
    f.apply(1, m);
    EXPECT_EQ(f.fx.adopted, std::vector<PlayerId>{2});
}

TEST(InputIntake, ASpectatorsTableNeverVotesButReportsCounts) {
    Fixture f;
    f.apply(1, Fixture::own(0, inputs(7, 4)));
    InputMessage m;
    m.has_extension = true;
    m.slots = {entry(1, SlotState::Disconnected, 1, 3), entry(2, SlotState::Running, 5, 0)};
    f.apply(3, m);
    EXPECT_TRUE(f.fx.votes.empty());
    EXPECT_TRUE(f.fx.adopted.empty());
    EXPECT_TRUE(f.links[3].has_count[1]);
    EXPECT_EQ(f.links[3].counts[1], 3u);
    EXPECT_TRUE(f.links[3].table_seen[2]);
}

TEST(InputIntake, ASpectatorFollowsTheViewOfThePlayersThatServeIt) {
    Fixture f(Role::Spectator);
    InputMessage m;
    m.has_extension = true;
    m.slots = {entry(2, SlotState::Disconnected, 1), entry(1, SlotState::Disconnected, 0)};
    f.apply(0, m);
    EXPECT_TRUE(f.fx.votes.empty());
    EXPECT_EQ(f.fx.adopted, std::vector<PlayerId>{2});  // the newer epoch only
}

TEST(InputIntake, ATableCountOfOurStreamIsAnAck) {
    Fixture f;
    f.sync.add_local_input(inputs(1, 1), 0);
    f.sync.add_local_input(inputs(1, 1), 1);
    ASSERT_EQ(f.sync.queue(0).confirmed_count(), 2u);
    InputMessage m;
    m.has_extension = true;
    m.slots = {entry(0, SlotState::Running, 0, 2)};
    f.apply(3, m);  // a spectator reports what it holds of our stream
    EXPECT_EQ(f.links[3].remote_ack, 2u);
    EXPECT_EQ(f.fx.acks, 1);
}

}  // namespace
}  // namespace lockroll::rollback
