// The confirmation floors (rollback/confirm_floors.h) on their own: which frames a session may
// confirm, and how far back it keeps its own and the other streams, over links built by hand.
#include "rollback/confirm_floors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

using namespace lockroll::rollback;

namespace {
constexpr std::uint32_t kNoLimit = std::numeric_limits<std::uint32_t>::max();

std::vector<PeerLink> links(std::size_t peers, std::size_t slots) {
    std::vector<PeerLink> v;
    for (std::size_t p = 0; p < peers; ++p) {
        v.emplace_back(8, 60);
        v.back().reset_lifecycle(slots);
    }
    return v;
}

void report(PeerLink& l, PlayerId slot, std::uint32_t count) {
    l.has_count[slot] = true;
    l.counts[slot] = count;
}

// Shown frame 100, all of it confirmable, states saved 20 frames back, no relayed input unverified.
ConfirmBounds at_frame_100(int others) {
    ConfirmBounds b;
    b.confirmable = 100;
    b.frame = 100;
    b.unverified = 100;
    b.saved_span = 20;
    b.others = others;
    return b;
}

LivePeer all_but(std::vector<PlayerId> dead) {
    return [dead](PlayerId p) { return std::find(dead.begin(), dead.end(), p) == dead.end(); };
}
}  // namespace

TEST(ConfirmFloors, ResendFloorIsTheLowestAckOfALivePeer) {
    auto l = links(4, 4);
    l[0].remote_ack = 50;  // ourselves: not live
    l[1].remote_ack = 40;
    l[2].remote_ack = 30;
    l[3].remote_ack = 10;  // dropped: no longer holds our inputs back
    EXPECT_EQ(resend_floor(l, all_but({0, 3}), 0, 64), 30u);
    EXPECT_EQ(resend_floor(l, all_but({0}), 0, 64), 10u);
}

TEST(ConfirmFloors, ResendFloorWithNoLivePeerIsNoLimitNotAPinnedFrame) {
    auto l = links(3, 3);
    l[1].remote_ack = 7;
    EXPECT_EQ(resend_floor(l, all_but({0, 1, 2}), 0, 64), kNoLimit);
}

// Players never wait for a spectator: one that stopped stepping (its ack stuck at 10 while we
// sent 200) holds our stream at most spectator_lag_bound() (48 of 64) behind what we sent; a
// player's ack holds it wherever it is.
TEST(ConfirmFloors, ASpectatorHoldsTheResendFloorOnlyWithinTheLagBound) {
    static_assert(spectator_lag_bound(64) == 48);
    auto l = links(4, 3);  // slots 0..2, a spectator in link 3
    l[1].remote_ack = 199;
    l[2].remote_ack = 198;
    l[3].role = Role::Spectator;
    l[3].remote_ack = 10;
    EXPECT_EQ(resend_floor(l, all_but({0}), 200, 64), 200u - 48u);
    l[3].remote_ack = 190;  // within the bound: it holds like anyone
    EXPECT_EQ(resend_floor(l, all_but({0}), 200, 64), 190u);
    l[3].remote_ack = 199;
    l[2].remote_ack = 10;  // a player far behind still holds it: we need it to have our inputs
    EXPECT_EQ(resend_floor(l, all_but({0}), 200, 64), 10u);
}

// A spectator is cut loose once it trails what we sent by more than the bound, and only once it
// reported our stream (just welcomed by a peer that did not serve its snapshot, its ack is 0).
TEST(ConfirmFloors, ASpectatorBeyondTheLagBoundIsCutLoose) {
    auto l = links(4, 3);
    PeerLink& s = l[3];
    s.role = Role::Spectator;
    EXPECT_FALSE(spectator_lags(s, 0, 200, 64));  // nothing reported yet
    report(s, 0, 152);
    s.remote_ack = 152;
    EXPECT_FALSE(spectator_lags(s, 0, 200, 64));  // 48 behind: the bound
    s.remote_ack = 151;
    EXPECT_TRUE(spectator_lags(s, 0, 200, 64));
    l[1].remote_ack = 10;
    report(l[1], 0, 10);
    EXPECT_FALSE(spectator_lags(l[1], 0, 200, 64));  // a player is never cut loose for lag
}

TEST(ConfirmFloors, KeepFloorIsTheLowestCountALivePeerOtherThanItsPlayerReported) {
    auto l = links(4, 4);
    report(l[1], 2, 100);
    report(l[2], 2, 20);   // the slot's own player: it never needs its own stream relayed
    report(l[3], 2, 60);
    EXPECT_EQ(keep_floor(2, l, all_but({0}), 0, 0, 1024), 60u);
    EXPECT_EQ(keep_floor(2, l, all_but({0, 3}), 0, 0, 1024), 100u);  // a dropped peer: not
    // Nobody reported the stream: nothing to keep for (the ring's own limit stands).
    EXPECT_EQ(keep_floor(1, l, all_but({0}), 0, 0, 1024), kNoLimit);
}

TEST(ConfirmFloors, AServedSnapshotsPinHoldsEveryStreamUntilItLapses) {
    auto l = links(3, 3);
    report(l[1], 2, 90);
    l[1].pin_from = 40;
    l[1].pin_until_us = 5'000'000;
    EXPECT_EQ(keep_floor(2, l, all_but({0}), 5'000'000, 0, 1024), 40u);
    EXPECT_EQ(keep_floor(2, l, all_but({0}), 5'000'001, 0, 1024), 90u);
    EXPECT_EQ(keep_floor(2, l, all_but({0, 1}), 1'000'000, 0, 1024), kNoLimit);  // its peer gone
}

TEST(ConfirmFloors, KeepFloorNeverMoreThanHalfTheRingBehindConfirmation) {
    auto l = links(3, 3);
    report(l[1], 2, 10);  // a peer that stopped acknowledging
    EXPECT_EQ(keep_floor(2, l, all_but({0}), 0, 1000, 1024), 1000u - 512u);
    EXPECT_EQ(keep_floor(2, l, all_but({0}), 0, 300, 1024), 10u);
}

TEST(ConfirmFloors, WhatAPeerHoldsOfOursIsItsAckAndOurGuestsCounts) {
    auto l = links(2, 4);
    l[1].remote_ack = 50;
    EXPECT_EQ(held_of_ours(l[1], {}), 50u);
    const std::vector<PlayerId> guests{2, 3};
    EXPECT_EQ(held_of_ours(l[1], guests), 0u);  // a guest's stream not reported: none held
    report(l[1], 2, 45);
    report(l[1], 3, 70);
    EXPECT_EQ(held_of_ours(l[1], guests), 45u);
}

TEST(ConfirmFloors, WithNobodyToWaitForEverythingConfirmableIs) {
    ConfirmBounds b = at_frame_100(0);  // a spectator, or a view of two under PlayOnAlone
    b.unverified = 0;
    EXPECT_EQ(confirm_limit(b, {}), 100u);
}

TEST(ConfirmFloors, ConfirmationWaitsUntilAMajorityHoldsOurInputs) {
    ConfirmBounds b = at_frame_100(2);  // a view of five: us and two more
    const std::vector<std::uint32_t> held{90, 85, 95, 86};
    EXPECT_EQ(confirm_limit(b, held), 90u);  // the second highest
    b.confirmable = 88;                      // never past a running slot's inputs
    EXPECT_EQ(confirm_limit(b, held), 88u);
}

TEST(ConfirmFloors, CutOffFromAMajorityConfirmationStopsAtTheOldestSavedState) {
    const ConfirmBounds b = at_frame_100(2);
    const std::vector<std::uint32_t> one_live{99};  // fewer live peers than a majority needs
    EXPECT_EQ(confirm_limit(b, one_live), 80u);
    const std::vector<std::uint32_t> behind{10, 12};
    EXPECT_EQ(confirm_limit(b, behind), 80u);  // nor behind what is saved
}

TEST(ConfirmFloors, AnUnverifiedRelayedInputHoldsConfirmationBackAsFarAsStatesAreSaved) {
    ConfirmBounds b = at_frame_100(1);
    const std::vector<std::uint32_t> held{100};
    b.unverified = 90;
    EXPECT_EQ(confirm_limit(b, held), 90u);
    b.unverified = 50;
    EXPECT_EQ(confirm_limit(b, held), 80u);
}
