// The session lifecycle in virtual time, part 6 of 6: spectators cut off, through kills and
// rejoins at loss, on small queues, and players that never wait for a spectator.

#include "tests/rollback/lifecycle_support.h"

namespace lockroll::rollback {
namespace {

// Issue 21: a spectator cut off from every player for 10 s (past disconnect_us: they stop
// serving it, it hears nobody). Healed, it must follow the match again -- by a fresh snapshot,
// its old view being gone -- and end on the players' checksums. Before, it stayed on the frame
// it was cut off at: the players ignored it for good, and it never learned it was dropped.
TEST(Lifecycle, SpectatorCutOffFromEveryPlayerFollowsAgainOnceHealed) {
    SessionConfig cfg = real_config(3, 8);
    cfg.max_spectators = 1;
    const auto scene = make_scene(3, 10);
    Cluster cluster(scene, cfg, {15000, 3000}, 47);
    cluster.run_frames(100);
    Client& spectator = start_newcomer(cluster, scene, cfg, Role::Spectator, 3, 1);
    cluster.run_frames(300, 30'000'000);
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
    bool cut = true;
    split(cluster, {3}, cut);
    cluster.run([](const Cluster&) { return false; }, 10'000'000);
    cut = false;
    rejoin_when_dropped(cluster);
    cluster.run_frames(1500, 60'000'000);
    cluster.settle(1500);
    const Client& watcher = *cluster.clients[3];
    ASSERT_EQ(watcher.session->phase(), SessionPhase::Running) << watcher.session->failure();
    EXPECT_EQ(watcher.session->config().role, Role::Spectator);
    EXPECT_EQ(events_of(watcher, Kind::SnapshotLoaded).size(), 2u);  // the first, then after the heal
    EXPECT_GE(watcher.session->confirmed_frame(), 1500u);
    expect_equal_at(cluster, 1500);
    for (PlayerId p : {0u, 1u, 2u}) {
        EXPECT_TRUE(events_of(*cluster.clients[p], Kind::Partitioned).empty()) << "client " << p;
        EXPECT_EQ(cluster.clients[p]->session->slot_state(0), SlotState::Running);
    }
}

// lockroll live's kill + rejoin case in virtual time, at 5 % loss with 30 ms of jitter and
// live_test's 1.5 s disconnect timeout: three players reach frame 150, a spectator comes, slot 2
// is killed at 200 and a new process rejoins it at 400; the match runs to kLast.
struct SpectatorThroughKillAndRejoin {
    static constexpr std::uint32_t kLast = 1200;
    sim::SceneDesc scene = make_scene(3, 10);
    SessionConfig cfg = [] {
        SessionConfig c = real_config(3, 8);
        c.max_spectators = 1;
        c.interrupt_us = 500'000;
        c.disconnect_us = 1'500'000;
        return c;
    }();
    Cluster cluster;
    explicit SpectatorThroughKillAndRejoin(std::uint64_t seed) : cluster(scene, cfg, {25000, 30000, 50000}, seed) {
        cluster.run_frames(150, 30'000'000);
    }
    Client& start_spectator() { return start_newcomer(cluster, scene, cfg, Role::Spectator, 3, 1); }
    void kill_and_rejoin() {
        cluster.run_frames(200, 30'000'000);
        cluster.kill(2);
        cluster.run_frames(400, 30'000'000);
        start_newcomer(cluster, scene, cfg, Role::Joiner, 2, 999);
        cluster.run_frames(kLast, 60'000'000);
        cluster.settle(kLast);
    }
    // Slot 2 is back everywhere; the spectator followed throughout -- never failed, never
    // dropped, one snapshot only -- and confirmed kLast on the players' checksum.
    void expect_spectator_followed(const Client& spectator) const {
        for (PlayerId p : {0u, 1u, 2u}) {
            const Client& c = *cluster.clients[p];
            ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
            EXPECT_EQ(c.session->slot_state(2), SlotState::Running) << "client " << p << ": slot 2 did not rejoin";
        }
        ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
        EXPECT_TRUE(events_of(spectator, Kind::Failed).empty());
        EXPECT_TRUE(events_of(spectator, Kind::Kicked).empty()) << events_of(spectator, Kind::Kicked)[0]->detail;
        EXPECT_EQ(events_of(spectator, Kind::SnapshotLoaded).size(), 1u);
        EXPECT_GE(spectator.session->confirmed_frame(), kLast) << "the spectator stopped at frame " << spectator.session->frame();
        expect_equal_at(cluster, kLast);
        const auto it = spectator.confirmed.find(kLast);
        ASSERT_NE(it, spectator.confirmed.end());
        EXPECT_EQ(it->second, cluster.clients[0]->confirmed.at(kLast));
        for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
    }
};

// Issue 21, what was seen: "a spectator in a kill + rejoin run (3 players, 5 % loss) timed out
// once". Over five seeds. It passes on the tree before issue 21 as well (1f05175: 40 seeds,
// rollback and lockstep), so it guards and did not catch: in virtual time every player welcomes
// the spectator before it loads. The next test forces the order real processes showed.
TEST(Lifecycle, SpectatorFollowsAKillAndRejoinAtFivePercentLoss) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        SpectatorThroughKillAndRejoin m(seed);
        Client& spectator = m.start_spectator();
        m.kill_and_rejoin();
        m.expect_spectator_followed(spectator);
    }
}

// Issue 21's spectator timeout, the mechanism found over real processes (docs/reliability.md,
// "Kill and rejoin"): at 5 % loss a spectator's connections to the players come up at different
// times (an ENet connect retried after 0.5 s, 1 s...), and it asks the first player that welcomed
// it for its snapshot. When that was slot 2, which is then killed, and the others had not
// welcomed it by the time it loaded, nobody served it any more: a running spectator said hello to
// nobody and ignored late welcomes, so slots 0 and 1 never heard of it (or timed it out), and it
// stopped at the kill for good while the match went on. Here the spectator's links to slots 0
// and 1 pass nothing until it has loaded slot 2's snapshot (connections that came up late).
// Before the fix it stopped at frames 214-240 (5 seeds of 5) and confirmed nothing more; now it
// says hello to every running slot that has not welcomed it (as a joiner does), takes their late
// welcomes, and follows the match to the players' final.
TEST(Lifecycle, SpectatorWhoseHostIsKilledBeforeTheOthersWelcomedItFollowsOn) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        SpectatorThroughKillAndRejoin m(seed);
        bool late = true;  // the spectator's connections to slots 0 and 1 are not up yet
        m.cluster.filter = [&late](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
            return !late || !((from == 3 && to < 2) || (to == 3 && from < 2));
        };
        Client& spectator = m.start_spectator();
        m.cluster.run([&](const Cluster&) { return !events_of(spectator, Kind::SnapshotLoaded).empty(); }, 10'000'000);
        ASSERT_EQ(events_of(spectator, Kind::SnapshotLoaded).size(), 1u) << spectator.session->failure();
        ASSERT_EQ(events_of(spectator, Kind::SnapshotLoaded)[0]->peer, 2u) << "its host must be the slot to be killed";
        late = false;
        m.kill_and_rejoin();
        m.expect_spectator_followed(spectator);
        // Slots 0 and 1 serve it since their late welcomes (it never had to start over).
        std::set<PlayerId> late_welcomes;
        for (const SessionEvent* e : events_of(spectator, Kind::Synchronizing))
            if (e->reason == SessionEvent::Reason::LateWelcome) late_welcomes.insert(e->peer);
        EXPECT_EQ(late_welcomes, (std::set<PlayerId>{0, 1}));
    }
}

// Issue 21, the same run over real processes with the host itself killed (lockroll live
// --kill 0@200 --spectate-at 190, 5 % loss: the spectator ran out its connect timeout in 2 runs of
// 3): slot 0 welcomed the spectator, then died before it answered its snapshot request. A dead
// host stays welcomed in the spectator's links, and the spectator asked the first welcomed host
// again and again -- slot 0, for good. Here slot 0 dies the moment the spectator asks it. Before
// the fix the spectator never loaded; now an unanswered ask moves on to the next host, and the
// spectator follows the two survivors to their final.
TEST(Lifecycle, SpectatorWhoseHostDiesBeforeItsOfferAsksAnother) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        SpectatorThroughKillAndRejoin m(seed);
        bool asked = false;  // the spectator asked slot 0, which is dead from then on
        m.cluster.filter = [&asked](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
            if (from == 3 && to == 0 && peek_kind(b) == MessageKind::SnapshotRequest) asked = true;
            return !asked || (from != 0 && to != 0);
        };
        // As net::PeerRunner does: a spectator the players timed out while it waited for the
        // dead host's offer (they hear nothing from it meanwhile) is told so, and starts again.
        rejoin_when_dropped(m.cluster);
        Client& spectator = m.start_spectator();
        m.cluster.run([&](const Cluster&) { return asked; }, 10'000'000);
        ASSERT_TRUE(asked) << "the spectator must ask slot 0 first";
        m.cluster.kill(0);
        constexpr std::uint32_t kLast = 900;
        m.cluster.run_frames(kLast, 60'000'000);
        m.cluster.settle(kLast);
        ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
        ASSERT_EQ(events_of(spectator, Kind::SnapshotLoaded).size(), 1u);
        EXPECT_NE(events_of(spectator, Kind::SnapshotLoaded)[0]->peer, 0u);
        EXPECT_GE(spectator.session->confirmed_frame(), kLast);
        expect_equal_at(m.cluster, kLast);
        const auto it = spectator.confirmed.find(kLast);
        ASSERT_NE(it, spectator.confirmed.end());
        EXPECT_EQ(it->second, m.cluster.clients[1]->confirmed.at(kLast));
    }
}

// Three players on 64-frame queues reach frame 150; then a spectator comes (by a snapshot).
struct SpectatorOnSmallQueues {
    sim::SceneDesc scene = make_scene(3, 10);
    SessionConfig cfg = [] {
        SessionConfig c = real_config(3, 8);
        c.max_spectators = 1;
        c.input_capacity = 64;
        return c;
    }();
    Cluster cluster{scene, cfg, {25000}, 3};
    Client& spectator = (cluster.run_frames(150, 30'000'000), start_newcomer(cluster, scene, cfg, Role::Spectator, 3, 1));
};

// A spectator that came by a snapshot of frame 165 follows the players 300 frames past its
// queues' capacity (64 here), and the players never wait for it. It failed while the Cluster
// gave a spectator no input at all: Session::advance refused every tick as a bad local input,
// the spectator moved by catch_up alone, its queues' floors never rose, and it stopped for good
// at frame 229 (165 + 64) with no event -- and the players, whose resend floor its acks held,
// stopped 64 frames later. net::PeerRunner passes a spectator one input, as the Cluster now does.
TEST(Lifecycle, SpectatorBySnapshotOutlivesItsInputCapacity) {
    SpectatorOnSmallQueues m;
    auto& [scene, cfg, cluster, spectator] = m;
    constexpr std::uint32_t kLast = 600;
    cluster.run_frames(kLast, 30'000'000);
    cluster.settle(kLast, 10'000'000);
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
    ASSERT_EQ(events_of(spectator, Kind::SnapshotLoaded).size(), 1u);
    EXPECT_GT(kLast, events_of(spectator, Kind::SnapshotLoaded)[0]->frame + 2 * cfg.input_capacity);
    for (const auto& c : cluster.clients) EXPECT_GE(c->session->confirmed_frame(), kLast);
    expect_equal_at(cluster, kLast);
}

// Players wait for players only. A spectator whose process still talks but no longer steps (a
// hung game loop, or a game that passes it input of the wrong size, which advance() refuses)
// must not stop the players: they play on far past their queues' capacity. It failed on main
// (67925ec): all three players stopped at frame 360 for good, with no event, the spectator's
// acknowledgements holding each player's resend floor (resend_floor() counted every live link,
// spectators too, with no bound), so their own queues filled. Now a spectator more than
// spectator_lag_bound() (48 of 64 here) behind is cut loose: the players drop it and answer it
// "dropped", and the spectator, kicked, says why it stopped; started again, it follows by a
// fresh snapshot (as after a timeout: SpectatorCutOffFromEveryPlayerFollowsAgainOnceHealed).
TEST(Lifecycle, PlayersDoNotWaitForASpectatorThatStopsStepping) {
    SpectatorOnSmallQueues m;
    auto& [scene, cfg, cluster, spectator] = m;
    cluster.run_frames(250, 30'000'000);
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
    cluster.before_tick = [](PlayerId id, Client& c) {
        if (id == 3) c.skip_ticks = 1;  // polls (and acknowledges) every tick, never steps
    };
    const std::uint32_t stuck_at = spectator.session->frame();
    constexpr std::uint32_t kLast = 800;
    // The players keep their pace: kLast - 250 frames in their time plus 2 s of slack (the
    // stall before the fix was for good).
    const std::uint64_t started = cluster.now();
    const std::uint64_t pace_us = std::uint64_t{kLast - 250} * 1'000'000 / static_cast<std::uint64_t>(cfg.tick_rate);
    cluster.run([](const Cluster& c) { return c.clients[0]->session->frame() >= kLast; }, 15'000'000);
    EXPECT_LE(cluster.now() - started, pace_us + 2'000'000) << "the players stalled";
    cluster.settle(kLast, 10'000'000);
    EXPECT_LE(spectator.session->frame(), stuck_at + 1);
    for (PlayerId p : {0u, 1u, 2u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_GE(c.session->frame(), kLast) << "client " << p << " waited for the spectator";
        EXPECT_GE(c.session->confirmed_frame(), kLast) << "client " << p;
        // It no longer holds them: dropped (told so), not merely outrun.
        ASSERT_FALSE(events_of(c, Kind::Disconnected).empty()) << "client " << p;
        EXPECT_EQ(events_of(c, Kind::Disconnected).back()->peer, 3u) << "client " << p;
        EXPECT_EQ(events_of(c, Kind::Disconnected).back()->reason, SessionEvent::Reason::SpectatorLagged) << "client " << p;
    }
    expect_equal_at(cluster, kLast);  // the players: the spectator failed
    // The spectator says why it stopped: the players dropped it.
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Failed);
    EXPECT_NE(spectator.session->failure().find("dropped"), std::string::npos) << spectator.session->failure();
    // Its game loop back, its runner starts it again: it follows by a fresh snapshot.
    rejoin_when_dropped(cluster);
    constexpr std::uint32_t kAfter = 1200;
    cluster.run_frames(kAfter, 30'000'000);
    cluster.settle(kAfter, 10'000'000);
    const Client& watcher = *cluster.clients[3];
    ASSERT_EQ(watcher.session->phase(), SessionPhase::Running) << watcher.session->failure();
    EXPECT_EQ(watcher.session->config().role, Role::Spectator);
    EXPECT_EQ(events_of(watcher, Kind::Kicked).size(), 1u);
    EXPECT_EQ(events_of(watcher, Kind::SnapshotLoaded).size(), 2u);  // the first, then after the cut
    EXPECT_GE(watcher.session->confirmed_frame(), kAfter);
    expect_equal_at(cluster, kAfter);
}

}  // namespace
}  // namespace lockroll::rollback
