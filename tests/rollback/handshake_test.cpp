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
    Fixture s(Role::Spectator, 2);
    Handshake hs(s.config, s.view);
    EXPECT_TRUE(s.hellos(hs, SessionPhase::Running, 2'000'000).empty()) << "a spectator talks to its host only";
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

}  // namespace
}  // namespace lockroll::rollback
