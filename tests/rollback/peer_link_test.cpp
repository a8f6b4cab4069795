// PeerLink (rollback/peer_link.h) on its own: the sticky error, the smoothed round trip, and the
// echoed stamps both sessions put on their input messages.
#include "rollback/peer_link.h"

#include <gtest/gtest.h>

using namespace lockroll::rollback;

TEST(PeerLink, ErrorIsStickyAfterMaxBadPacketsAndClearedOnlyByARejoin) {
    PeerLink l(3, 60);
    EXPECT_FALSE(l.note_malformed("a"));
    EXPECT_FALSE(l.note_malformed("b"));
    EXPECT_TRUE(l.note_malformed("c"));  // the third tips it
    EXPECT_FALSE(l.note_malformed("d"));  // only once
    EXPECT_TRUE(l.error());
    EXPECT_EQ(l.malformed(), 4u);
    EXPECT_EQ(l.last_error(), "d");
    l.clear_error();
    EXPECT_FALSE(l.error());
    EXPECT_EQ(l.malformed(), 0u);
}

TEST(PeerLink, RoundTripIsSmoothedAndJitterIsTheMeanDeviation) {
    PeerLink l(8, 60);
    EXPECT_FALSE(l.has_rtt());
    l.add_rtt_sample(80000);
    EXPECT_EQ(l.rtt_us(), 80000u);
    EXPECT_EQ(l.rtt_var_us(), 0u);
    l.add_rtt_sample(160000);
    EXPECT_EQ(l.rtt_us(), (7 * 80000u + 160000u) / 8);
    EXPECT_EQ(l.rtt_var_us(), 80000u / 4);
}

TEST(PeerLink, NoEchoUntilThePeerSentAStamp) {
    PeerLink l(8, 60);
    const auto s = l.outgoing_stamps(1'234'500);
    EXPECT_EQ(s.stamp, 12345);
    EXPECT_EQ(s.echo, PeerLink::kNoEcho);
    EXPECT_EQ(s.hold, PeerLink::kNoEcho);
    // Our own stamp never reads as "no echo": 0xFFFF units map to 0.
    EXPECT_EQ(l.outgoing_stamps(0xFFFFull * 100).stamp, 0);
}

TEST(PeerLink, EchoedStampGivesTheRoundTripMinusTheHold) {
    PeerLink a(8, 60), b(8, 60);
    // a sends at 1.000 s; b receives at 1.020 s and answers at 1.035 s (held 15 ms); a hears it
    // at 1.060 s: a round trip of 60 ms minus 15 ms held = 45 ms.
    const auto out = a.outgoing_stamps(1'000'000);
    b.take_stamps(out.stamp, out.echo, out.hold, 1'020'000);
    EXPECT_FALSE(b.has_rtt());  // nothing of b's was echoed
    const auto back = b.outgoing_stamps(1'035'000);
    EXPECT_EQ(back.echo, out.stamp);
    EXPECT_EQ(back.hold, 150);
    a.take_stamps(back.stamp, back.echo, back.hold, 1'060'000);
    ASSERT_TRUE(a.has_rtt());
    EXPECT_EQ(a.rtt_us(), 45'000u);
    // a now echoes b's stamp.
    EXPECT_EQ(a.outgoing_stamps(1'070'000).echo, back.stamp);
    EXPECT_EQ(a.outgoing_stamps(1'070'000).hold, 100);
}

TEST(PeerLink, StampsThatCannotBeTrueGiveNoSample) {
    PeerLink l(8, 60);
    // A hold longer than the time since our stamp, an echo without a hold, a hold without an
    // echo: no sample, but the sender's stamp is still taken.
    const auto out = l.outgoing_stamps(2'000'000);
    l.take_stamps(7, out.stamp, 500, 2'010'000);  // held 50 ms of a 10 ms round trip
    EXPECT_FALSE(l.has_rtt());
    l.take_stamps(8, out.stamp, PeerLink::kNoEcho, 2'010'000);
    EXPECT_FALSE(l.has_rtt());
    l.take_stamps(9, PeerLink::kNoEcho, 0, 2'010'000);
    EXPECT_FALSE(l.has_rtt());
    EXPECT_EQ(l.outgoing_stamps(2'020'000).echo, 9);
}
