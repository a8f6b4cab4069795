// PeerLink (rollback/peer_link.h) on its own: the sticky error, the smoothed round trip, the
// echoed stamps both sessions put on their input messages, and the slot table's schedule.
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

TEST(PeerLink, SilenceInterruptsOnceAndTimesOutUntilHeardAgain) {
    PeerLink l(8, 60);
    EXPECT_FALSE(l.check_silence(10'000'000, 750'000, 5'000'000).timed_out);  // never heard: nothing
    l.mark_heard(1'000'000);
    auto s = l.check_silence(1'700'000, 750'000, 5'000'000);
    EXPECT_FALSE(s.interrupted_now);
    EXPECT_EQ(s.silent_us, 700'000u);
    s = l.check_silence(1'750'000, 750'000, 5'000'000);
    EXPECT_TRUE(s.interrupted_now);
    EXPECT_FALSE(s.timed_out);
    EXPECT_FALSE(l.check_silence(1'800'000, 750'000, 5'000'000).interrupted_now);  // once per silence
    EXPECT_TRUE(l.check_silence(6'000'000, 750'000, 5'000'000).timed_out);
    EXPECT_FALSE(l.check_silence(60'000'000, 750'000, 0).timed_out);  // 0: never
    EXPECT_TRUE(l.hear(6'100'000));   // ends the interruption
    EXPECT_FALSE(l.hear(6'200'000));
    EXPECT_FALSE(l.check_silence(6'300'000, 750'000, 5'000'000).interrupted_now);
    // A caller's time before the last datagram is no silence.
    EXPECT_EQ(l.check_silence(1'000, 750'000, 5'000'000).silent_us, 0u);
}

TEST(PeerLink, HellosAndRefusalsAreRateLimited) {
    PeerLink l(8, 60);
    EXPECT_TRUE(l.hello_due(0, 50'000));
    EXPECT_FALSE(l.hello_due(49'999, 50'000));
    EXPECT_TRUE(l.hello_due(50'000, 50'000));
    EXPECT_TRUE(l.refusal_quiet_for(0, 100'000));
    l.mark_refusal(10);
    EXPECT_FALSE(l.refusal_quiet_for(100'009, 100'000));
    EXPECT_TRUE(l.refusal_quiet_for(100'010, 100'000));
}

TEST(PeerLink, SyncWelcomesCountRoundTripsAndKeepTheWorst) {
    PeerLink l(8, 60);
    EXPECT_TRUE(l.sync_welcome(1'000'000, false, 1'080'000));  // the first
    EXPECT_FALSE(l.sync_welcome(1'100'000, false, 1'140'000));
    EXPECT_FALSE(l.sync_welcome(2'000'000, true, 1'900'000));  // an echo from the future: no sample
    EXPECT_TRUE(l.welcomed);
    EXPECT_TRUE(l.has_remote_frame);  // it said it runs
    EXPECT_EQ(l.roundtrips, 3);
    EXPECT_EQ(l.max_sync_rtt_us, 80'000u);
    EXPECT_EQ(l.rtt_us(), (7 * 80'000u + 40'000u) / 8);
    EXPECT_EQ(l.last_heard_us, 1'900'000u);
}

TEST(PeerLink, LateWelcomeAndAcceptedHelloMakeTheLinkLive) {
    PeerLink a(8, 60);
    a.interrupted = true;
    a.late_welcome(5, 100, 30'100);
    EXPECT_TRUE(a.welcomed && a.heard && a.has_remote_frame);
    EXPECT_FALSE(a.interrupted);
    EXPECT_EQ(a.welcomed_epoch, 5);
    EXPECT_EQ(a.rtt_us(), 30'000u);
    PeerLink b(8, 60);
    b.accept_hello(Role::Joiner, 77, std::uint8_t{3}, 500);
    EXPECT_TRUE(b.welcomed);
    EXPECT_EQ(b.role, Role::Joiner);
    EXPECT_EQ(b.incarnation, 77u);
    EXPECT_EQ(b.welcomed_epoch, 3);
    EXPECT_EQ(b.last_heard_us, 500u);
    b.accept_hello(Role::Spectator, 78, std::nullopt, 900);  // heard before: not moved; no epoch: kept
    EXPECT_EQ(b.last_heard_us, 500u);
    EXPECT_EQ(b.welcomed_epoch, 3);
}

// A new process for the id (a spectator back after the players timed it out): its
// predecessor's silence is not its own. The accepted hello marks it heard now; before, the old
// last_heard_us stayed, and the next silence check timed the newcomer out at once, again after
// every hello (issue 21, a spectator after a healed partition).
TEST(PeerLink, ANewProcessIsHeardFromItsOwnHelloNotItsPredecessorsLastWord) {
    PeerLink l(8, 60);
    l.accept_hello(Role::Spectator, 7, std::nullopt, 1'000'000);
    EXPECT_TRUE(l.check_silence(12'000'000, 750'000, 5'000'000).timed_out);
    l.welcomed = false;  // timed out: no longer served
    l.reset_lifecycle(3);  // its next process says hello
    l.accept_hello(Role::Spectator, 8, std::nullopt, 12'000'000);
    EXPECT_EQ(l.last_heard_us, 12'000'000u);
    const PeerLink::Silence s = l.check_silence(12'100'000, 750'000, 5'000'000);
    EXPECT_FALSE(s.timed_out);
    EXPECT_FALSE(s.interrupted_now);
}

TEST(PeerLink, AcksOnlyMoveForwardAndItsFrameIsEstimatedFromTheReport) {
    PeerLink l(8, 60);
    EXPECT_TRUE(l.take_ack(10));
    EXPECT_FALSE(l.take_ack(9));
    EXPECT_FALSE(l.take_ack(10));
    EXPECT_EQ(l.remote_ack, 10u);
    l.add_rtt_sample(100'000);
    l.note_remote_frame(600, -3, 10'000'000);
    EXPECT_EQ(l.remote_advantage, -3);
    // Half a round trip (3 frames at 60 Hz) plus the time since the report, capped at interrupt_us.
    EXPECT_EQ(l.estimated_frame(10'000'000, 750'000, 60), 603);
    EXPECT_EQ(l.estimated_frame(10'500'000, 750'000, 60), 633);
    EXPECT_EQ(l.estimated_frame(20'000'000, 750'000, 60), 648);
    EXPECT_EQ(l.estimated_frame(9'000'000, 750'000, 60), 603);  // time before the report: none
}

TEST(PeerLink, ChecksumsRideEveryNewCheckpointThenRepeatTheNewest) {
    PeerLink l(8, 60);
    std::uint16_t frames[3];
    std::uint64_t sums[3];
    const auto have = [](std::uint32_t f) { return f % 8 == 0 ? std::optional<std::uint64_t>(1000 + f) : std::nullopt; };
    // The first message: the newest checkpoints up to the max (16, 24, 32 of interval 8).
    ASSERT_EQ(l.pick_checksums(32, 8, 2, 3, have, frames, sums), 3);
    EXPECT_EQ(frames[0], 16);
    EXPECT_EQ(frames[2], 32);
    EXPECT_EQ(sums[2], 1032u);
    // Nothing newer: the newest again, until it rode `repeats` messages.
    ASSERT_EQ(l.pick_checksums(32, 8, 2, 3, have, frames, sums), 1);
    EXPECT_EQ(frames[0], 32);
    EXPECT_EQ(l.pick_checksums(32, 8, 2, 3, have, frames, sums), 0);
    // Newer ones: those since the last announced only.
    ASSERT_EQ(l.pick_checksums(48, 8, 2, 3, have, frames, sums), 2);
    EXPECT_EQ(frames[0], 40);
    EXPECT_EQ(frames[1], 48);
    // A checksum no longer held is left out.
    const auto none = [](std::uint32_t) { return std::optional<std::uint64_t>(); };
    EXPECT_EQ(l.pick_checksums(56, 8, 2, 3, none, frames, sums), 0);
}

// The slot table's schedule (issue 21): a change rides at once and then after 1, 2, 4, ...
// messages, `copies` times; a table that changed once is refreshed every refresh_us; one that
// never changed (the starting view) is never due; a rejoined process gets it as a change.
TEST(PeerLink, SlotTableGoesOnChangeInSpreadCopiesThenOnTheRefresh) {
    PeerLink l(8, 60);
    const std::vector<std::uint16_t> start{0x0100, 0x0100, 0x0100};
    const std::vector<std::uint16_t> vote{0x0100, 0x0100, 0x0201};  // slot 2 "gone" in epoch 1
    constexpr std::uint64_t kRefresh = 2'000'000;
    l.table_assumed(start, 0);
    std::uint64_t now = 0;
    std::vector<std::uint64_t> sent_at;  // message numbers that carried the table
    const auto run = [&](const std::vector<std::uint16_t>& entries, int messages) {
        for (int i = 0; i < messages; ++i, now += 16'667) {
            if (l.table_due(entries, now, kRefresh)) {
                l.table_sent(entries, now, 8);
                sent_at.push_back(l.messages_sent);
            }
            ++l.messages_sent;
        }
    };
    run(start, 600);  // 10 s of a table that never changed
    EXPECT_TRUE(sent_at.empty());
    run(vote, 100);  // the change, at message 600
    EXPECT_EQ(sent_at, (std::vector<std::uint64_t>{600, 601, 602, 604, 608, 616, 632, 664}));
    sent_at.clear();
    run(vote, 240);  // then the refresh: 2 s (120 messages) after the last copy, and again
    EXPECT_EQ(sent_at, (std::vector<std::uint64_t>{784, 904}));
    sent_at.clear();
    // A copy sent for another reason counts: the next is spread from it.
    const std::uint64_t change = l.messages_sent;
    l.table_sent(start, now, 8);  // the vote withdrawn, first copy
    ++l.messages_sent;
    now += 16'667;
    l.table_sent(start, now, 8);  // a second copy (relays rode)
    ++l.messages_sent;
    now += 16'667;
    run(start, 3);
    EXPECT_EQ(sent_at, (std::vector<std::uint64_t>{change + 2, change + 4}));
    // A new process in the slot has heard nothing: the table is a change to it.
    l.reset_lifecycle(3);
    EXPECT_TRUE(l.table_due(start, now, kRefresh));
    // Refresh 0: never refreshed.
    PeerLink quiet(8, 60);
    quiet.table_sent(vote, 0, 1);
    EXPECT_FALSE(quiet.table_due(vote, 10'000'000, 0));
    EXPECT_TRUE(quiet.table_due(vote, 10'000'000, kRefresh));
}

TEST(PeerLink, NetworkStatsForAnOverlay) {
    PeerLink l(8, 60);
    l.add_rtt_sample(40'000);
    l.remote_ack = 90;
    l.interrupted = true;
    PeerStats traffic;
    traffic.bytes_sent = 125'000;  // a megabit
    traffic.bytes_received = 250'000;
    OverlayClock at;
    at.frame = 100;
    at.seconds = 2;
    at.now_us = 5'000'000;
    at.interrupt_us = 500'000;
    NetworkStats n = network_stats(l, traffic, at, 95u);
    EXPECT_EQ(n.ping_us, 40'000u);
    EXPECT_DOUBLE_EQ(n.kbps_sent, 500);
    EXPECT_DOUBLE_EQ(n.kbps_received, 1000);
    EXPECT_EQ(n.send_queue, 5u) << "our inputs it has not acknowledged";
    EXPECT_EQ(n.frames_behind, 0) << "no frame reported yet";
    EXPECT_TRUE(n.interrupted);
    EXPECT_EQ(network_stats(l, traffic, at, std::nullopt).send_queue, 0u) << "a spectator sends no inputs";
    EXPECT_EQ(network_stats(l, traffic, at, 80u).send_queue, 0u);
    l.has_remote_frame = true;  // frame 90 reported now, half a round trip (1.2 frames) ago
    l.remote_frame = 90;
    l.remote_frame_time_us = at.now_us;
    EXPECT_EQ(network_stats(l, traffic, at, 95u).frames_behind, 100 - 91);
    at.seconds = 0;
    EXPECT_EQ(network_stats(l, traffic, at, 95u).kbps_sent, 0) << "not started";
}
