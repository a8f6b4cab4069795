// Handshake (rollback/handshake.h) on its own, over hand-fed links (no session, no network):
// who gets hellos when, and when a player starts frame 0.
#include "rollback/handshake.h"

#include <gtest/gtest.h>

#include <vector>

#include "tests/rollback/peer_links.h"

namespace lockroll::rollback {
namespace {

struct Fixture {
    SessionConfig config;
    Membership view;
    std::vector<PeerLink> links = testing::fresh_links(3);
    std::vector<Datagram> out;

    explicit Fixture(Role role = Role::Player, PlayerId me = 0) : view(3, me, TwoPlayerRule::PlayOnAlone) {
        config.players = 3;
        config.local_player = me;
        config.role = role;
        config.incarnation = 77;
    }
    std::vector<PlayerId> hellos(Handshake& h, SessionPhase phase, std::uint64_t now) {
        out.clear();
        h.poll_hellos(links, phase, 5, now, out);
        std::vector<PlayerId> to;
        for (const Datagram& d : out) {
            EXPECT_FALSE(d.reliable) << "hellos are said again until answered: unreliable";
            HelloMessage m;
            EXPECT_EQ(decode(d.bytes, m), nullptr);
            EXPECT_EQ(m.incarnation, 77u);
            EXPECT_EQ(m.scene_checksum, 5u);
            EXPECT_EQ(m.stamp_us, now);
            to.push_back(d.peer);
        }
        return to;
    }
    void welcome(Handshake& h, PlayerId from, int times, bool running, std::uint64_t now) {
        WelcomeMessage w;
        w.running = running;
        w.echo_us = now;
        for (int i = 0; i < times; ++i) h.sync_welcome(links[from], true, w, now);
    }
};

TEST(Handshake, APlayerSaysHelloToEveryRunningSlotUntilFrameZero) {
    Fixture f;
    Handshake h(f.config, f.view);
    EXPECT_EQ(f.hellos(h, SessionPhase::Synchronizing, 1000), (std::vector<PlayerId>{1, 2}));
    EXPECT_TRUE(f.hellos(h, SessionPhase::Synchronizing, 1001).empty()) << "resent only after hello_resend_us";
    EXPECT_EQ(f.hellos(h, SessionPhase::Synchronizing, 1000 + f.config.hello_resend_us).size(), 2u);
    EXPECT_TRUE(f.hellos(h, SessionPhase::Running, 10'000'000).empty());
    f.view.set(2, SlotState::Absent, 0);
    EXPECT_EQ(f.hellos(h, SessionPhase::Synchronizing, 20'000'000), (std::vector<PlayerId>{1})) << "absent: nobody to greet";
}

TEST(Handshake, ANewcomerSaysHelloUntilEveryRunningSlotWelcomedIt) {
    Fixture f(Role::Joiner, 2);
    Handshake h(f.config, f.view);
    f.welcome(h, 0, f.config.sync_roundtrips, true, 500);
    EXPECT_EQ(f.hellos(h, SessionPhase::Synchronizing, 1000), (std::vector<PlayerId>{1}));
    EXPECT_EQ(f.hellos(h, SessionPhase::Running, 2'000'000), (std::vector<PlayerId>{1})) << "loaded: until welcomed";
    // A spectator as well (issue 21): served only by its host, it stopped for good once that
    // host was killed before the others' welcomes came.
    Fixture s(Role::Spectator, 2);
    Handshake hs(s.config, s.view);
    s.welcome(hs, 0, s.config.sync_roundtrips, true, 500);
    EXPECT_EQ(s.hellos(hs, SessionPhase::Running, 2'000'000), (std::vector<PlayerId>{1})) << "loaded: until welcomed";
    s.links[1].late_welcome(0, 0, 2'000'010);
    EXPECT_TRUE(s.hellos(hs, SessionPhase::Running, 3'000'000).empty()) << "every running slot welcomed it";
}

// Issue 21: a joiner's view before it loads is its config's at frame 0. Slot 1 absent there may
// run now (it joined after slot 2's predecessor died), and only a process that welcomed us
// answers our snapshot's vetting query: before loading a joiner greets every other process's
// slot; once it runs, the view it loaded decides again.
TEST(Handshake, AJoinerThatHasNotLoadedGreetsSlotsItsConfigSaysAreAbsent) {
    Fixture f(Role::Joiner, 2);
    f.view.set(1, SlotState::Absent, 0);
    Handshake h(f.config, f.view);
    EXPECT_EQ(f.hellos(h, SessionPhase::Synchronizing, 1000), (std::vector<PlayerId>{0, 1}));
    f.links[0].welcomed = f.links[1].welcomed = false;
    EXPECT_EQ(f.hellos(h, SessionPhase::Running, 2'000'000), (std::vector<PlayerId>{0})) << "loaded: the view decides";
    Fixture p(Role::Player, 0);
    p.view.set(1, SlotState::Absent, 0);
    Handshake hp(p.config, p.view);
    EXPECT_EQ(p.hellos(hp, SessionPhase::Synchronizing, 1000), (std::vector<PlayerId>{2})) << "a player: its view";
}

TEST(Handshake, StartsAfterSyncRoundtripsOrAtOnceBehindAPlayerThatStarted) {
    Fixture f;
    Handshake h(f.config, f.view);
    EXPECT_FALSE(h.ready_to_start(f.links, SessionPhase::Synchronizing));
    f.welcome(h, 1, f.config.sync_roundtrips, false, 100);
    f.welcome(h, 2, f.config.sync_roundtrips - 1, false, 100);
    EXPECT_EQ(h.first_welcome_us(), 100u);
    EXPECT_FALSE(h.ready_to_start(f.links, SessionPhase::Synchronizing));
    f.welcome(h, 2, 1, false, 200);
    EXPECT_TRUE(h.ready_to_start(f.links, SessionPhase::Synchronizing));
    EXPECT_FALSE(h.ready_to_start(f.links, SessionPhase::Running));

    Fixture g;
    Handshake early(g.config, g.view);
    g.welcome(early, 1, 1, true, 100);  // slot 1 runs already
    EXPECT_FALSE(early.ready_to_start(g.links, SessionPhase::Synchronizing)) << "slot 2 never answered";
    g.welcome(early, 2, 1, false, 100);
    EXPECT_TRUE(early.ready_to_start(g.links, SessionPhase::Synchronizing));
}

TEST(Handshake, StartReturnsTheWorstSyncRoundTripAndHearsEveryone) {
    Fixture f;
    Handshake h(f.config, f.view);
    WelcomeMessage w;
    w.echo_us = 0;
    h.sync_welcome(f.links[1], true, w, 30'000);
    h.sync_welcome(f.links[2], true, w, 80'000);
    EXPECT_EQ(h.start(f.links, 90'000), 80'000u);
    EXPECT_EQ(f.links[1].last_heard_us, 90'000u);
    EXPECT_EQ(h.first_welcome_us(), 30'000u);
}

TEST(Handshake, AHellosAnswerCarriesOurMatchSceneItsStampAndItsSlotsEpoch) {
    Fixture f;
    f.config.match_id = 42;
    Handshake h(f.config, f.view);
    HelloMessage m;
    m.stamp_us = 1234;
    f.view.set(1, SlotState::Running, 3);
    const WelcomeMessage w = h.answer(1, m, true, 9, Refusal::None);
    EXPECT_EQ(w.match_id, 42u);
    EXPECT_EQ(w.scene_checksum, 9u);
    EXPECT_EQ(w.echo_us, 1234u);
    EXPECT_TRUE(w.running);
    EXPECT_EQ(w.slot_epoch, 3);
    EXPECT_EQ(w.refusal, Refusal::None);
    EXPECT_EQ(h.answer(5, m, false, 9, Refusal::Retry).slot_epoch, 0) << "a spectator's id has no slot";
}

TEST(Handshake, AdmissionIsToldTheSendersLinkAndSlot) {
    Fixture f;
    Handshake h(f.config, f.view);
    f.links[1].accept_hello(Role::Player, 555, std::uint8_t{0}, 10);
    HelloContext c = h.hello_context(1, f.links[1], true, 9, true);
    EXPECT_TRUE(c.from_slot && c.running && c.welcomed && c.slot_running && c.welcomed_in_this_epoch && c.handed_off_by_me);
    EXPECT_EQ(c.incarnation, 555u);
    EXPECT_EQ(c.scene_checksum, 9u);
    f.view.set(1, SlotState::Running, 1);  // handed over since: another epoch
    EXPECT_FALSE(h.hello_context(1, f.links[1], true, 9, false).welcomed_in_this_epoch);
    c = h.hello_context(4, f.links[1], true, 9, true);  // a spectator's id: nothing of a slot
    EXPECT_FALSE(c.from_slot || c.slot_running || c.handed_off_by_me);
}

TEST(Handshake, OnlyANewcomersLinkStartsOverForAnotherProcess) {
    Fixture f;
    Handshake h(f.config, f.view);
    EXPECT_TRUE(h.new_process(1, f.links[1], Role::Joiner)) << "never welcomed";
    EXPECT_FALSE(h.new_process(1, f.links[1], Role::Player)) << "a player's link never starts over here";
    f.links[1].accept_hello(Role::Joiner, 7, std::uint8_t{0}, 10);
    EXPECT_FALSE(h.new_process(1, f.links[1], Role::Joiner)) << "its slot still runs: the same joiner";
    EXPECT_TRUE(h.new_process(1, f.links[1], Role::Spectator)) << "another role";
    f.view.set(1, SlotState::Disconnected, 1);
    EXPECT_TRUE(h.new_process(1, f.links[1], Role::Joiner)) << "dropped into a new epoch: the next joiner";
}

TEST(Handshake, ARefusalIsAnsweredEvery100MsAndReportedOnceASecond) {
    Fixture f;
    PeerLink& l = f.links[1];
    l.mark_refusal(1'000'000);
    EXPECT_TRUE(Handshake::refusal_answered(Refusal::Retry, l, 1'000'001)) << "retry: always";
    EXPECT_FALSE(Handshake::refusal_answered(Refusal::MatchId, l, 1'050'000));
    EXPECT_TRUE(Handshake::refusal_answered(Refusal::MatchId, l, 1'100'000));
    EXPECT_FALSE(Handshake::refusal_reported(l, 1'500'000));
    EXPECT_TRUE(Handshake::refusal_reported(l, 2'000'000));
}

TEST(Handshake, WhatAWelcomeMeans) {
    using Act = Handshake::WelcomeVerdict::Act;
    Fixture f;
    f.config.match_id = 42;
    Handshake h(f.config, f.view);
    WelcomeMessage w;
    EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Synchronizing, f.links[1], 9).act, Act::SyncRoundTrip);
    EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Transferring, f.links[1], 9).act, Act::SyncRoundTrip);
    EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Running, f.links[1], 9).act, Act::Ignore) << "a player runs already";
    w.refusal = Refusal::Retry;
    EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Synchronizing, f.links[1], 9).act, Act::Ignore);
    w.refusal = Refusal::Disconnected;
    EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Running, f.links[1], 9).act, Act::VoteGone);
    w.refusal = Refusal::Scene;
    w.scene_checksum = 8;
    const auto refused = h.judge_welcome(1, w, SessionPhase::Synchronizing, f.links[1], 9);
    EXPECT_EQ(refused.act, Act::Refused);
    EXPECT_NE(refused.why.find("peer 1 refused"), std::string::npos) << refused.why;
    EXPECT_NE(refused.why.find("theirs 8, ours 9"), std::string::npos) << refused.why;
    w.refusal = Refusal::MatchId;
    w.match_id = 41;
    EXPECT_NE(h.judge_welcome(1, w, SessionPhase::Running, f.links[1], 9).why.find("theirs 41, ours 42"), std::string::npos);

    Fixture s(Role::Spectator, 2);
    Handshake hs(s.config, s.view);
    w.refusal = Refusal::Disconnected;
    EXPECT_EQ(hs.judge_welcome(0, w, SessionPhase::Running, s.links[0], 9).act, Act::SpectatorDropped);
    Fixture j(Role::Joiner, 2);
    Handshake hj(j.config, j.view);
    EXPECT_EQ(hj.judge_welcome(0, w, SessionPhase::Synchronizing, j.links[0], 9).act, Act::Ignore)
        << "a joiner still synchronizing has no slot to lose yet";
    EXPECT_EQ(hj.judge_welcome(0, w, SessionPhase::Running, j.links[0], 9).act, Act::VoteGone);
}

// Issue 21: a player still synchronizing that a running slot answers retry or disconnected is a
// restarted process (only another process of a slot the match runs, or dropped, is told that);
// a first start is welcomed, and a joiner, a running player or a peer that does not run says
// nothing of the kind.
TEST(Handshake, ARetryOrDisconnectedFromARunningSlotTellsASynchronizingPlayerItRestarted) {
    Fixture f(Role::Player, 2);
    Handshake h(f.config, f.view);
    WelcomeMessage w;
    w.running = true;
    EXPECT_FALSE(h.judge_welcome(0, w, SessionPhase::Synchronizing, f.links[0], 9).restarted) << "a welcome";
    for (Refusal r : {Refusal::Retry, Refusal::Disconnected}) {
        w.refusal = r;
        w.running = true;
        const auto v = h.judge_welcome(0, w, SessionPhase::Synchronizing, f.links[0], 9);
        EXPECT_TRUE(v.restarted) << refusal_name(r);
        EXPECT_EQ(v.act, r == Refusal::Retry ? Handshake::WelcomeVerdict::Act::Ignore : Handshake::WelcomeVerdict::Act::VoteGone);
        EXPECT_FALSE(h.judge_welcome(0, w, SessionPhase::Running, f.links[0], 9).restarted) << refusal_name(r);
        w.running = false;
        EXPECT_FALSE(h.judge_welcome(0, w, SessionPhase::Synchronizing, f.links[0], 9).restarted) << refusal_name(r);
    }
    w.refusal = Refusal::Scene;
    w.running = true;
    EXPECT_FALSE(h.judge_welcome(0, w, SessionPhase::Synchronizing, f.links[0], 9).restarted);
    Fixture j(Role::Joiner, 2);
    Handshake hj(j.config, j.view);
    w.refusal = Refusal::Retry;
    EXPECT_FALSE(hj.judge_welcome(0, w, SessionPhase::Synchronizing, j.links[0], 9).restarted);
}

// A newcomer (joiner, or spectator since issue 21) that runs takes a late welcome from a running
// slot; a player needs none.
TEST(Handshake, ARunningNewcomerTakesALateWelcomeOnceFromARunningSlot) {
    using Act = Handshake::WelcomeVerdict::Act;
    for (Role role : {Role::Joiner, Role::Spectator}) {
        SCOPED_TRACE(role == Role::Joiner ? "joiner" : "spectator");
        Fixture j(role, 2);
        Handshake h(j.config, j.view);
        WelcomeMessage w;
        w.running = true;
        EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Running, j.links[1], 9).act, Act::LateWelcome);
        j.links[1].late_welcome(0, 0, 10);
        EXPECT_EQ(h.judge_welcome(1, w, SessionPhase::Running, j.links[1], 9).act, Act::Ignore) << "welcomed already";
        w.running = false;
        EXPECT_EQ(h.judge_welcome(0, w, SessionPhase::Running, j.links[0], 9).act, Act::Ignore) << "not running itself";
        w.running = true;
        j.view.set(0, SlotState::Disconnected, 1);
        EXPECT_EQ(h.judge_welcome(0, w, SessionPhase::Running, j.links[0], 9).act, Act::Ignore) << "a dropped slot";
    }
    Fixture p;
    Handshake hp(p.config, p.view);
    WelcomeMessage w;
    w.running = true;
    EXPECT_EQ(hp.judge_welcome(1, w, SessionPhase::Running, p.links[1], 9).act, Act::Ignore) << "a player needs none";
}

}  // namespace
}  // namespace lockroll::rollback
