// rollback/rejoin.h: the pure rules of a (re)joiner (docs/sessions.md, Join step 5).
#include "rollback/rejoin.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>


namespace lockroll::rollback {
namespace {

constexpr std::uint32_t kLead = 21;  // a 320 ms round trip at 60 Hz, + 2 (SessionImpl::lead_frames)

// The 16-minute soak's slot 2 (issue 21): handed over at H = 39,407 while the match was at
// ~39,384, it caught up in a fraction of a second, and then the match stepped ~54 frames a second
// (stalls under 20 % loss, time-sync waits, a kill's 2 s stall) while the joiner sent one input per
// tick. Under the old rule (one per tick until frame + delay meets the stream) its stream ran
// ~600 frames ahead of every frame played within a minute; the provider's next snapshot carried
// them and the next joiner refused it ("too many inputs in a stream", over input_capacity / 2).
TEST(Rejoin, AJoinerStaysWithinItsLeadWhenTheMatchStepsSlowerThanItsTicks) {
    const int delay = 3;
    const std::uint32_t handoff = 39'407;
    std::uint32_t frame = 39'384, count = handoff;
    bool joining = true;
    std::uint32_t ahead_most = 0;
    for (int tick = 0; tick < 3600; ++tick) {  // a minute at 60 Hz
        const std::uint32_t target = frame + static_cast<std::uint32_t>(delay);
        const JoinerInput in = joiner_input(joining, count, target, kLead);
        joining = in.joining;
        // Sync::add_local_input: the input goes to max(target, min_frame), and only past the
        // stream's end (the frames between are filled with the last input).
        const std::uint32_t to = std::max(target, in.min_frame);
        if (to >= count) count = to + 1;
        const bool stalled = tick >= 2000 && tick < 2120;  // a kill: 2 s without a step
        if (!stalled && tick % 10 != 0) ++frame;           // otherwise 54 frames a second
        ahead_most = std::max(ahead_most, count - (frame + static_cast<std::uint32_t>(delay)));
    }
    EXPECT_LE(ahead_most, kLead + 2);
}

TEST(Rejoin, AJoinerCatchingUpSendsOneInputPerTickFromItsStreamsEnd) {
    // Loaded frame 1,000 with H = 1,020: within the lead, each tick's input continues the stream
    // at the match's pace.
    JoinerInput in = joiner_input(true, 1'020, 1'003, kLead);
    EXPECT_TRUE(in.joining);
    EXPECT_EQ(in.min_frame, 1'020u);
    in = joiner_input(true, 1'021, 1'010, kLead);
    EXPECT_EQ(in.min_frame, 1'021u);
    // Its frame + delay met the stream: a player like any other.
    in = joiner_input(true, 1'040, 1'040, kLead);
    EXPECT_FALSE(in.joining);
    EXPECT_EQ(in.min_frame, 0u);
    EXPECT_FALSE(joiner_input(false, 2'000, 1'500, kLead).joining);
}

TEST(Rejoin, AJoinerALeadAheadHoldsItsInputUntilItsFrameComesWithinIt) {
    // Frame + delay at 1,000, the stream at 1,000 + kLead + 1: no new input (min_frame 0: Sync
    // adds at frame + delay, below the stream's end), still joining so the tick is no dropped
    // input.
    const JoinerInput in = joiner_input(true, 1'000 + kLead + 1, 1'000, kLead);
    EXPECT_TRUE(in.joining);
    EXPECT_EQ(in.min_frame, 0u);
    EXPECT_EQ(joiner_input(true, 1'000 + kLead, 1'000, kLead).min_frame, 1'000 + kLead);
}

// Issue 21: a spectator the players stopped serving (cut off from all of them past
// disconnect_us, then told it was dropped) comes back as a spectator, by a fresh snapshot; it
// used to be no drop at all, and it stayed on the frame it was cut off at.
TEST(Rejoin, ADroppedSpectatorComesBackAsASpectator) {
    SessionConfig c;
    c.players = 3;
    c.local_player = 3;
    c.role = Role::Spectator;
    c.handshake = false;
    EXPECT_FALSE(can_rejoin(c, false));
    EXPECT_TRUE(can_rejoin(c, true));
    EXPECT_EQ(rejoin_refusal(c), "");
    const SessionConfig again = rejoin_config(c, 0x1234);
    EXPECT_EQ(again.role, Role::Spectator);
    EXPECT_EQ(again.local_player, 3u);
    EXPECT_TRUE(again.handshake);
    EXPECT_EQ(again.scene_checksum, 0x1234u);
    c.role = Role::Player;
    c.local_player = 1;
    EXPECT_EQ(rejoin_config(c, 0).role, Role::Joiner);
}

// A process hosting guest slots cannot rejoin yet, and says why (its outcome carries it).
TEST(Rejoin, AHostOfGuestSlotsCannotRejoinAndSaysWhy) {
    SessionConfig c;
    c.players = 3;
    c.slot_hosts = {0, 0, 2};
    c.local_player = 0;
    EXPECT_FALSE(can_rejoin(c, true));
    EXPECT_NE(rejoin_refusal(c).find("several slots"), std::string::npos) << rejoin_refusal(c);
    EXPECT_EQ(drop_failure(c), "dropped from the match by the other peers; it cannot rejoin: " + rejoin_refusal(c));
    c.local_player = 2;  // the other process plays one slot
    EXPECT_TRUE(can_rejoin(c, true));
    EXPECT_EQ(rejoin_refusal(c), "");
    EXPECT_EQ(drop_failure(c), "dropped from the match by the other peers");
}

}  // namespace
}  // namespace lockroll::rollback
