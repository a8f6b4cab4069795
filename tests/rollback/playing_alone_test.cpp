// AloneSince (rollback/playing_alone.h) on its own: a drop that leaves the local process the only
// running voter of its view sets the frame, whatever the match's size; a rejoin clears it.
#include "rollback/playing_alone.h"

#include <gtest/gtest.h>

#include <vector>

namespace lockroll::rollback {
namespace {

SessionEvent event(SessionEvent::Kind kind, PlayerId peer, std::uint32_t frame) {
    SessionEvent e;
    e.kind = kind;
    e.peer = peer;
    e.frame = frame;
    return e;
}

SessionEvent dropped(PlayerId peer, std::uint32_t frame) { return event(SessionEvent::Kind::Disconnected, peer, frame); }

using Voters = std::vector<PlayerId>;

TEST(AloneSince, TwoPlayersTheOthersDropLeavesTheSurvivorAlone) {
    AloneSince a;
    a.settle(Voters{0, 1}, 0);
    EXPECT_FALSE(a.since());
    a.saw(dropped(1, 150), 2);
    a.settle(Voters{0}, 0);
    EXPECT_EQ(a.since(), 150u);
    a.settle(Voters{0}, 0);  // later drains keep the drop's frame
    EXPECT_EQ(a.since(), 150u);
}

// Issue 21: a match of three shrunk to two by a majority's drop, then the two-player rule: alone
// from the second drop, not the first (the first left a view of two). Both drops in one drain
// give the second's frame too.
TEST(AloneSince, ThreePlayersShrunkToTwoAreAloneOnlyAfterTheSecondDrop) {
    AloneSince a;
    a.saw(dropped(2, 120), 3);
    a.settle(Voters{0, 1}, 0);
    EXPECT_FALSE(a.since()) << "a view of two is not alone";
    a.saw(dropped(1, 430), 3);
    a.settle(Voters{0}, 0);
    EXPECT_EQ(a.since(), 430u);

    AloneSince one_drain;
    one_drain.saw(dropped(2, 120), 3);
    one_drain.saw(dropped(1, 121), 3);
    one_drain.settle(Voters{0}, 0);
    EXPECT_EQ(one_drain.since(), 121u);
}

TEST(AloneSince, ARejoinClearsItAndTheNextDropSetsItAgain) {
    AloneSince a;
    a.saw(dropped(1, 150), 2);
    a.settle(Voters{0}, 0);
    a.saw(event(SessionEvent::Kind::Joined, 1, 400), 2);
    a.settle(Voters{0, 1}, 0);
    EXPECT_FALSE(a.since());
    a.saw(dropped(1, 700), 2);
    a.settle(Voters{0}, 0);
    EXPECT_EQ(a.since(), 700u);
}

// Alone from the start (every other slot absent) dropped nobody; a spectator's timeout (a peer id
// beyond the slots) is no drop; a spectator is no voter, so never alone.
TEST(AloneSince, NoDropOfASlotNoAlone) {
    AloneSince start;
    start.settle(Voters{0}, 0);
    EXPECT_FALSE(start.since());
    start.saw(dropped(3, 90), 3);  // spectator 3 of a 3-player match
    start.settle(Voters{0}, 0);
    EXPECT_FALSE(start.since());
    AloneSince spectator;
    spectator.saw(dropped(1, 150), 2);
    spectator.settle(Voters{0}, 2);
    EXPECT_FALSE(spectator.since());
}

// A session dropped by the others (kicked) still holds them in its view: not alone.
TEST(AloneSince, AKickedSessionIsNotAlone) {
    AloneSince a;
    a.saw(event(SessionEvent::Kind::Kicked, 0, 300), 3);
    a.settle(Voters{0, 1, 2}, 0);
    EXPECT_FALSE(a.since());
}

}  // namespace
}  // namespace lockroll::rollback
