// The session lifecycle in virtual time, part 2 of 6: kills, restarts and lone survivors; a
// restart hello is a claim; lockstep kills on a loaded machine.

#include "tests/rollback/lifecycle_support.h"

#include "rollback/restart_claim.h"

namespace lockroll::rollback {
namespace {

// Kill one of three at frame 200: the others report it interrupted, then disconnected, agree on
// the frame its neutral input starts, stall no longer than the timeout, and end equal. Then a
// new process rejoins its slot by snapshot and ends equal too.
void kill_and_rejoin(int window) {
    const auto scene = make_scene(3, 20);
    const SessionConfig cfg = real_config(3, window);
    Cluster cluster(scene, cfg, {30000, 8000, 50000}, 5);
    cluster.run_frames(200);
    cluster.kill(2);
    const std::uint64_t killed_at = cluster.now();
    cluster.run_frames(600, 60'000'000);
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(events_of(c, Kind::Interrupted).size(), 1u) << "client " << p;
        ASSERT_EQ(events_of(c, Kind::Disconnected).size(), 1u) << "client " << p;
        EXPECT_EQ(c.session->slot_state(2), SlotState::Disconnected);
        const auto neutral = events_of(c, Kind::NeutralFrom);
        ASSERT_EQ(neutral.size(), 1u);
        // Stall bounded by the disconnect timeout (plus the agreement's round trips).
        EXPECT_LT(c.session->stats().stall_time_us, cfg.disconnect_us + 1'000'000);
        // The drop: the timeout, the votes' one-way trip, then the agreement's two round trips
        // (rollback/drop_agreement.h; 30 ms one way here).
        EXPECT_LT(events_of(c, Kind::Disconnected)[0]->at_us - killed_at, cfg.disconnect_us + 400'000);
    }
    EXPECT_EQ(events_of(*cluster.clients[0], Kind::NeutralFrom)[0]->frame,
              events_of(*cluster.clients[1], Kind::NeutralFrom)[0]->frame);
    cluster.settle(600);
    expect_equal_at(cluster, 600);

    // A new process for slot 2.
    SessionConfig again = cfg;
    again.local_player = 2;
    again.role = Role::Joiner;
    Client& joiner = cluster.start(2, scene, again, 999);
    cluster.run_frames(1000, 60'000'000);
    cluster.settle(1000);
    EXPECT_EQ(joiner.session->phase(), SessionPhase::Running);
    ASSERT_EQ(events_of(joiner, Kind::SnapshotLoaded).size(), 1u);
    EXPECT_EQ(cluster.clients[0]->session->slot_state(2), SlotState::Running);
    EXPECT_EQ(cluster.clients[1]->session->slot_state(2), SlotState::Running);
    expect_equal_at(cluster, 1000);
    // The joiner's own inputs count after the handoff: its player moved.
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
    // Its stream before the handoff is the owner's neutral input: it never sends those frames as
    // its own (they differed in the absent flag: a malformed message at every peer per join).
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().malformed_packets, 0u);
}

TEST(Lifecycle, KillAndRejoinRollback) { kill_and_rejoin(8); }

// Slot 1 of `players` dies at frame 200 and a new process for it says hello `down_us` later, in
// a new incarnation, as `role`. Each survivor votes the old process gone as soon as that has
// been silent for half interrupt_us (a hello while it still talks is only a claim: issue 21): a
// genuine restart says hello to all of them, so a majority forms at once (with two players the
// one vote) and drops it (detail `drop_detail`, with the votes) long before disconnect_us: the
// game barely stalls. As a joiner it rejoins by snapshot. As a player (restarted with its usual
// settings) it is refused as dropped, so it is kicked before it runs a frame (it used to be
// welcomed and start at frame 0 of a running match); started again as a joiner (what
// net::NetSession does on that kick) it rejoins.
void restart_after(Role role, std::uint64_t down_us, const std::string& drop_detail, SessionEvent::Reason drop_reason,
                   int players = 2) {
    const auto scene = make_scene(players, 10);
    const SessionConfig cfg = real_config(players, 8);
    Cluster cluster(scene, cfg, {15000}, 12);
    cluster.run_frames(200);
    cluster.kill(1);
    cluster.run([](const Cluster&) { return false; }, down_us);
    SessionConfig again = cfg;
    again.local_player = 1;
    again.role = role;
    const std::uint64_t restarted_at = cluster.now();
    Client* joiner = &cluster.start(1, scene, again, 31);
    if (role == Role::Player) {
        const Client& player = *joiner;
        cluster.run([&](const Cluster&) { return player.session->phase() == SessionPhase::Failed; }, 3'000'000);
        cluster.run([](const Cluster&) { return false; }, 100'000);  // its events drained by its next ticks
        ASSERT_EQ(player.session->phase(), SessionPhase::Failed) << "the restarted player was let in at frame 0";
        ASSERT_EQ(events_of(player, Kind::Kicked).size(), 1u);
        EXPECT_EQ(events_of(player, Kind::Kicked)[0]->reason, SessionEvent::Reason::VotedOut);
        ASSERT_EQ(events_of(player, Kind::Failed).size(), 1u);
        EXPECT_EQ(events_of(player, Kind::Failed)[0]->reason, SessionEvent::Reason::Dropped);
        EXPECT_TRUE(events_of(player, Kind::Synchronized).empty());
        EXPECT_EQ(player.session->frame(), 0u);
        cluster.kill(1);
        again.role = Role::Joiner;
        joiner = &cluster.start(1, scene, again, 31);
    }
    cluster.run_frames(600, 20'000'000);
    cluster.settle(600);
    for (int p = 0; p < players; ++p) {
        if (p == 1) continue;
        const Client& survivor = *cluster.clients[static_cast<std::size_t>(p)];
        ASSERT_EQ(events_of(survivor, Kind::Disconnected).size(), 1u) << "survivor " << p;
        EXPECT_EQ(events_of(survivor, Kind::Disconnected)[0]->detail, drop_detail) << "survivor " << p;
        EXPECT_EQ(events_of(survivor, Kind::Disconnected)[0]->reason, drop_reason)
            << "survivor " << p << ": " << reason_name(events_of(survivor, Kind::Disconnected)[0]->reason);
        // The claim stands interrupt_us / 2 (rollback/restart_claim.h); with three players the
        // agreement's two round trips follow (15 ms one way here).
        EXPECT_LT(events_of(survivor, Kind::Disconnected)[0]->at_us, restarted_at + 600'000) << "survivor " << p;
        EXPECT_LT(survivor.session->stats().stall_time_us, 3'000'000u) << "survivor " << p;
    }
    EXPECT_EQ(joiner->session->phase(), SessionPhase::Running);
    EXPECT_EQ(events_of(*joiner, Kind::SnapshotLoaded).size(), 1u);
    expect_equal_at(cluster, 600);
}

// With two players the single vote decides (the two-player rule), and the detail says so.
constexpr const char* kAloneRule = " (the two-player rule, play_on_alone: this process plays on alone)";
TEST(Lifecycle, FastRestartIsNoticedBeforeTheTimeout) {
    restart_after(Role::Joiner, 1'000'000, std::string("rejoining, by 1 of 2 votes") + kAloneRule,
                  SessionEvent::Reason::RejoiningTwoPlayerRule);
}
TEST(Lifecycle, RestartAsPlayerIsRefusedAsDroppedThenRejoinsAsJoiner) {
    restart_after(Role::Player, 300'000, std::string("restarted, by 1 of 2 votes") + kAloneRule,
                  SessionEvent::Reason::RestartedTwoPlayerRule);
}
TEST(Lifecycle, FastRestartOfOneOfThreeIsDroppedByTheTwoVotesBeforeTheTimeout) {
    restart_after(Role::Joiner, 1'000'000, "rejoining, agreed by 2 of 3 players", SessionEvent::Reason::Rejoining, 3);
}
TEST(Lifecycle, RestartAsPlayerOfOneOfThreeIsDroppedByTheTwoVotesThenRejoins) {
    restart_after(Role::Player, 300'000, "restarted, agreed by 2 of 3 players", SessionEvent::Reason::Restarted, 3);
}

// Runs `cluster` to frame 200 and writes to `h` what an outsider who overheard slot 1's first
// hello to peer 0 would forge from it: a joiner's hello of a new incarnation of slot 1, the
// claim a restarted process makes.
void run_and_forge_restart_hello(Cluster& cluster, HelloMessage& h) {
    std::vector<std::uint8_t> hello_bytes;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (from == 1 && to == 0 && hello_bytes.empty() && !b.empty() && b[0] == static_cast<std::uint8_t>(MessageKind::Hello))
            hello_bytes = b;
        return true;
    };
    cluster.run_frames(200);
    cluster.filter = nullptr;
    ASSERT_EQ(decode(hello_bytes, h), nullptr);
    h.role = Role::Joiner;
    h.incarnation += 12345;
}

// Issue 21, "a datagram is a claim, not a fact": an outsider sends one hello with slot 1's id,
// as a joiner of a new incarnation (what a restarted process says), at frame 200 while slot 1's
// own process plays on. Nobody may drop slot 1 on that word: it used to drop it at once at
// every peer it reached, with no vote, and with three players that peer's view left the
// others' and the whole match froze. A restart claim counts only once the slot's process has
// gone quiet (admit_hello); the hello is refused, counted and reported at each peer it reached.
void forged_restart_hello(int players, std::vector<PlayerId> targets) {
    const auto scene = make_scene(players, 10);
    const SessionConfig cfg = real_config(players, 8);
    Cluster cluster(scene, cfg, {15000, 3000}, 41);
    HelloMessage h;
    ASSERT_NO_FATAL_FAILURE(run_and_forge_restart_hello(cluster, h));
    std::set<PlayerId> sent;
    cluster.rewrite = [&](PlayerId from, PlayerId to, std::vector<std::uint8_t>& b) {
        if (from != 1 || sent.count(to) || std::find(targets.begin(), targets.end(), to) == targets.end()) return;
        b.clear();  // in place of one of slot 1's datagrams: one loss besides
        encode(h, b);
        sent.insert(to);
    };
    cluster.run_frames(800, 30'000'000);
    cluster.settle(800, 10'000'000);
    ASSERT_EQ(sent.size(), targets.size());
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        const Client& c = *cluster.clients[i];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << i << ": " << c.session->failure();
        EXPECT_GE(c.session->frame(), 800u) << "client " << i;
        EXPECT_GE(c.session->confirmed_frame(), 800u) << "client " << i;
        for (int s = 0; s < players; ++s)
            EXPECT_EQ(c.session->slot_state(static_cast<PlayerId>(s)), SlotState::Running) << "client " << i << " slot " << s;
        EXPECT_TRUE(events_of(c, Kind::Disconnected).empty()) << "client " << i;
        EXPECT_TRUE(events_of(c, Kind::Kicked).empty()) << "client " << i;
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << i;
    }
    for (PlayerId t : targets) {
        const Client& c = *cluster.clients[t];
        EXPECT_EQ(c.session->foreign_packets(), 1u) << "client " << t << ": the forged hello is counted";
        const auto refused = events_of(c, Kind::Refused);
        ASSERT_EQ(refused.size(), 1u) << "client " << t;
        EXPECT_EQ(refused[0]->peer, 1);
        EXPECT_NE(refused[0]->detail.find("restart"), std::string::npos) << refused[0]->detail;
        EXPECT_EQ(refused[0]->reason, SessionEvent::Reason::RestartDoubted) << refused[0]->detail;
    }
    expect_equal_at(cluster, 800);
}

TEST(Lifecycle, ForgedRestartHelloToOnePeerOfThreeDropsNobody) { forged_restart_hello(3, {0}); }
TEST(Lifecycle, ForgedRestartHelloToBothPeersOfThreeDropsNobody) { forged_restart_hello(3, {0, 2}); }
// Two players: one vote decides a drop (TwoPlayerRule::PlayOnAlone), so the claim alone must
// not be that vote while slot 1's process plays.
TEST(Lifecycle, ForgedRestartHelloInATwoPlayerMatchDropsNobody) { forged_restart_hello(2, {0}); }

constexpr std::uint64_t kClaimFromUs = 450'000, kClaimEveryUs = 50'000, kClaimAfterUs = 500'000;

// From frame 200 every datagram slot 1 sends is lost for burst_us; from kClaimFromUs into the
// burst until kClaimAfterUs after it an outsider claims slot 1 restarted to each of `targets`,
// every kClaimEveryUs, in place of one of slot 1's datagrams. Runs `cluster` until then; returns
// when the first claim was sent.
std::uint64_t forge_claims_in_a_loss_burst(Cluster& cluster, const std::vector<PlayerId>& targets, std::uint64_t burst_us) {
    HelloMessage h;
    run_and_forge_restart_hello(cluster, h);
    if (::testing::Test::HasFatalFailure()) return 0;
    std::vector<std::uint8_t> forged;
    encode(h, forged);
    const std::uint64_t burst_from = cluster.now(), burst_to = burst_from + burst_us;
    std::map<PlayerId, std::uint64_t> last_claim;  // per target
    std::uint64_t first_claim = 0;
    cluster.rewrite = [&](PlayerId from, PlayerId to, std::vector<std::uint8_t>& b) {
        const std::uint64_t now = cluster.now();
        if (from != 1 || now < burst_from + kClaimFromUs || now >= burst_to + kClaimAfterUs) return;
        if (std::find(targets.begin(), targets.end(), to) == targets.end()) return;
        if (last_claim.count(to) && now < last_claim[to] + kClaimEveryUs) return;
        b = forged;
        last_claim[to] = now;
        if (first_claim == 0) first_claim = now;
    };
    // Slot 1's own datagrams are lost during the burst; the outsider's hellos get through.
    cluster.filter = [&](PlayerId from, PlayerId, const std::vector<std::uint8_t>& b) {
        const std::uint64_t now = cluster.now();
        return from != 1 || now < burst_from || now >= burst_to || b == forged;
    };
    cluster.run([&](const Cluster& c) { return c.now() >= burst_to + kClaimAfterUs; }, burst_us + 2'000'000);
    cluster.rewrite = nullptr;
    cluster.filter = nullptr;
    for (PlayerId t : targets) EXPECT_GE(last_claim[t], burst_to) << "target " << t << ": claimed to the end";
    return first_claim;
}

// Issue 21, the gap the ForgedRestartHello tests leave: the outsider's hello lands while slot 1's process is
// genuinely silent. At frame 200 every datagram slot 1 sends is lost for 650 ms (a loss burst:
// more than interrupt_us / 2 = 375 ms, so the silence alone lets a restart claim in, and far
// less than disconnect_us = 5 s, so silence alone drops nobody). From 450 ms into the burst an
// outsider keeps claiming slot 1 restarted -- a joiner's hello of a new incarnation to each of
// `targets`, every 50 ms, in place of one of slot 1's datagrams, as a restarted process would --
// and goes on for 500 ms after the burst, when slot 1 is heard again. Nobody may drop it: an honest
// player whose silence ends before the drop timeout must not be dropped on a forged claim. On
// main the first such hello was this peer's vote at once: with two players it decided (0 plays
// on alone, slot 1 is dropped, and it is refused as dropped and kicked); with three, the two
// votes were a majority. A claim now counts only once the old process has stayed silent for
// restart_confirm_us after it began (rollback/restart_claim.h), and slot 1 spoke first.
void forged_restart_hello_in_a_loss_burst(int players, std::vector<PlayerId> targets) {
    constexpr std::uint64_t kBurstUs = 650'000;
    const auto scene = make_scene(players, 10);
    const SessionConfig cfg = real_config(players, 8);
    ASSERT_GT(kBurstUs, cfg.interrupt_us / 2);
    ASSERT_LT(kBurstUs, cfg.disconnect_us);
    Cluster cluster(scene, cfg, {15000, 3000}, 43);
    ASSERT_GT(forge_claims_in_a_loss_burst(cluster, targets, kBurstUs), 0u);
    cluster.run_frames(800, 30'000'000);
    cluster.settle(800, 10'000'000);
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        const Client& c = *cluster.clients[i];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << i << ": " << c.session->failure();
        EXPECT_GE(c.session->confirmed_frame(), 800u) << "client " << i;
        for (int s = 0; s < players; ++s)
            EXPECT_EQ(c.session->slot_state(static_cast<PlayerId>(s)), SlotState::Running) << "client " << i << " slot " << s;
        EXPECT_TRUE(events_of(c, Kind::Disconnected).empty())
            << "client " << i << ": " << events_of(c, Kind::Disconnected)[0]->detail;
        EXPECT_TRUE(events_of(c, Kind::Kicked).empty()) << "client " << i;
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << i;
    }
    expect_equal_at(cluster, 800);
}

TEST(Lifecycle, ForgedRestartHelloDuringALossBurstInATwoPlayerMatchDropsNobody) {
    forged_restart_hello_in_a_loss_burst(2, {0});
}
TEST(Lifecycle, ForgedRestartHelloDuringALossBurstToBothPeersOfThreeDropsNobody) {
    forged_restart_hello_in_a_loss_burst(3, {0, 2});
}

// What a forged claim can still do (docs/sessions.md, "A restart is a claim"): the burst lasts
// 1.5 s, longer than the window after the first claim, and the outsider keeps claiming. With
// two players peer 0's vote is the decision: slot 1 is dropped long before disconnect_us -- but
// never before the claim has stood restart_confirm_us -- and when its process is heard again it
// is refused as dropped, kicked, and rejoins by snapshot: a rejoin, not a split of the match.
TEST(Lifecycle, ForgedRestartHelloDuringALongerSilenceIsAVoteOnlyAfterTheWindowAndTheHonestPlayerRejoins) {
    const auto scene = make_scene(2, 10);
    const SessionConfig cfg = real_config(2, 8);
    Cluster cluster(scene, cfg, {15000, 3000}, 43);
    rejoin_when_dropped(cluster);
    const std::uint64_t first_claim = forge_claims_in_a_loss_burst(cluster, {0}, 1'500'000);
    ASSERT_GT(first_claim, 0u);
    cluster.run_frames(800, 30'000'000);
    cluster.settle(800, 10'000'000);
    const Client& survivor = *cluster.clients[0];
    const auto drops = events_of(survivor, Kind::Disconnected);
    ASSERT_EQ(drops.size(), 1u);
    EXPECT_EQ(drops[0]->reason, SessionEvent::Reason::RejoiningTwoPlayerRule) << drops[0]->detail;
    EXPECT_GE(drops[0]->at_us, first_claim + restart_confirm_us(cfg.interrupt_us)) << "before the claim stood";
    EXPECT_LT(drops[0]->at_us, first_claim + cfg.disconnect_us);
    const Client& honest = *cluster.clients[1];
    EXPECT_EQ(events_of(honest, Kind::Kicked).size(), 1u);
    EXPECT_EQ(events_of(honest, Kind::SnapshotLoaded).size(), 1u);
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_EQ(c.session->slot_state(1), SlotState::Running) << "client " << p;
    }
    expect_equal_at(cluster, 800);
}

TEST(Lifecycle, KillAndRejoinLockstep) { kill_and_rejoin(0); }

// A kick of a live player of three: its process keeps sending until it hears it was dropped.
// Client 2 votes it gone first, client 0 (the owner) `lead_us` later; a majority agrees and each
// applies the drop. Client 2's table carried its vote ("disconnected" in the next epoch) with
// what it held of slot 1's stream while slot 1 still ran there and its inputs still came in: the
// owner took that vote for the drop applied and started the neutral inputs at its own count,
// below inputs client 2 went on to confirm (the five-player freeze, seed 146: "desync frame 387").
// The owner must wait for the drop each peer applied, whose count can no longer grow.
void kick_a_live_player(std::uint64_t seed, std::uint64_t lead_us) {
    const auto scene = make_scene(3, 10);
    SessionConfig cfg = real_config(3, 8);
    cfg.input_delay = 0;
    Cluster cluster(scene, cfg, {20000, 8000}, seed);
    cluster.run_frames(200);
    cluster.clients[2]->session->disconnect_player(1, cluster.now());
    const std::uint64_t until = cluster.now() + lead_us;
    while (cluster.now() < until) cluster.step_event();
    cluster.clients[0]->session->disconnect_player(1, cluster.now());
    cluster.run_frames(500, 20'000'000);
    cluster.settle(500);
    EXPECT_EQ(events_of(*cluster.clients[1], Kind::Kicked).size(), 1u);
    std::set<std::uint32_t> neutral_from;
    for (PlayerId p : {0u, 2u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        ASSERT_EQ(events_of(c, Kind::Disconnected).size(), 1u) << "client " << p;
        EXPECT_NE(events_of(c, Kind::Disconnected)[0]->detail.find("kicked"), std::string::npos) << "client " << p;
        for (const SessionEvent* e : events_of(c, Kind::NeutralFrom)) neutral_from.insert(e->frame);
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << p;
        EXPECT_EQ(c.session->stats().malformed_packets, 0u) << "client " << p;
        EXPECT_TRUE(c.peer_errors.empty()) << "client " << p;
    }
    EXPECT_EQ(neutral_from.size(), 1u) << "slot 1's neutral input starts at different frames";
    expect_equal_at(cluster, 500);
}

TEST(Lifecycle, KickOfALivePlayerOfThreeStartsItsNeutralInputAfterEveryInputAPeerConfirmed) {
    for (std::uint64_t seed = 1; seed <= 8; ++seed)
        for (std::uint64_t lead_us : {0u, 30'000u, 100'000u}) {
            SCOPED_TRACE("seed " + std::to_string(seed) + ", owner votes " + std::to_string(lead_us / 1000) + " ms later");
            kick_a_live_player(seed, lead_us);
        }
}

// Issue 21, "the lone survivor freezes": every other player is killed from frame 200 on and the
// survivor plays on alone. Nothing may stop a match that has one live player: it must keep
// advancing and confirming frames far beyond input_capacity frames after the drop (the freeze
// came ~input_capacity frames after it), with no failure and no stall after the timeouts.
// Small queues (when asked) fill quickly, a short timeout ends the stall on the dead quickly.
// With three players they die one after another, each once the previous drop is agreed: a
// majority dying at once looks exactly like being the minority of a partition, where the one
// left must drop nobody (MajorityKilledAtOnceLeavesTheSurvivorPartitioned).
SessionConfig lone_config(int players, int window, std::uint32_t input_capacity) {
    SessionConfig cfg = real_config(players, window);
    cfg.input_capacity = input_capacity;
    cfg.disconnect_us = 1'500'000;
    cfg.interrupt_us = 500'000;
    return cfg;
}

void lone_survivor(int players, int window, std::uint32_t input_capacity, std::uint32_t frames) {
    const auto scene = make_scene(players, 10);
    const SessionConfig cfg = lone_config(players, window, input_capacity);
    Cluster cluster(scene, cfg, {20000, 4000}, 23);
    cluster.run_frames(200);
    for (int p = 1; p < players; ++p) {
        const auto victim = static_cast<PlayerId>(p);
        cluster.kill(victim);
        if (p + 1 == players) break;
        cluster.run([victim](const Cluster& c) { return c.clients[0]->session->slot_state(victim) != SlotState::Running; },
                    30'000'000);
        ASSERT_EQ(cluster.clients[0]->session->slot_state(victim), SlotState::Disconnected) << "slot " << p;
    }
    const std::uint32_t virtual_s = frames / 60 + 30;  // real time plus slack for the timeout
    cluster.run_frames(frames, std::uint64_t{virtual_s} * 1'000'000);
    cluster.settle(frames, 5'000'000);
    const Client& survivor = *cluster.clients[0];
    ASSERT_EQ(survivor.session->phase(), SessionPhase::Running) << survivor.session->failure();
    EXPECT_GE(survivor.session->frame(), frames);
    EXPECT_GE(survivor.session->confirmed_frame(), frames);
    EXPECT_GE(survivor.forward, frames);
    EXPECT_EQ(survivor.confirmed.count(frames), 1u);
    for (int p = 1; p < players; ++p) {
        EXPECT_EQ(survivor.session->slot_state(static_cast<PlayerId>(p)), SlotState::Disconnected) << "slot " << p;
    }
    EXPECT_EQ(events_of(survivor, Kind::Disconnected).size(), static_cast<std::size_t>(players - 1));
    EXPECT_TRUE(events_of(survivor, Kind::Failed).empty());
    // Its view was reduced to itself, whatever the match's size: its outcome says "alone" from
    // the last drop (rollback/playing_alone.h), which names the two-player rule.
    EXPECT_EQ(running_voters(*survivor.session), std::vector<PlayerId>{0});
    AloneSince alone;
    for (const SessionEvent& e : survivor.events) alone.saw(e, players);
    alone.settle(running_voters(*survivor.session), 0);
    EXPECT_EQ(alone.since(), events_of(survivor, Kind::Disconnected).back()->frame);
    EXPECT_NE(events_of(survivor, Kind::Disconnected).back()->detail.find("the two-player rule"), std::string::npos)
        << events_of(survivor, Kind::Disconnected).back()->detail;
    EXPECT_EQ(events_of(survivor, Kind::Disconnected).back()->reason, SessionEvent::Reason::TimedOutTwoPlayerRule);
    if (players > 2) {
        EXPECT_EQ(events_of(survivor, Kind::Disconnected).front()->reason, SessionEvent::Reason::TimedOut);
    }
    // Stalled only while the dead waited out their timeouts (one after another).
    EXPECT_LT(survivor.session->stats().stall_time_us,
              static_cast<std::uint64_t>(players - 1) * cfg.disconnect_us + 1'000'000);
}

TEST(Lifecycle, LoneSurvivorPlaysOnRollback) { lone_survivor(2, 8, 1024, 3000); }
TEST(Lifecycle, LoneSurvivorPlaysOnSmallQueues) { lone_survivor(2, 8, 64, 1000); }
TEST(Lifecycle, LoneSurvivorPlaysOnLockstep) { lone_survivor(2, 0, 64, 1000); }
TEST(Lifecycle, LoneSurvivorOfThreePlaysOn) { lone_survivor(3, 8, 64, 1000); }
TEST(Lifecycle, LoneSurvivorOfThreePlaysOnLockstep) { lone_survivor(3, 0, 1024, 3000); }

// Two of three die at the same moment. The survivor cannot tell this from being cut off from
// the other two, who would drop it and play on: it drops nobody, says Partitioned, and confirms
// nothing it could disagree on (issue 21: split matches). It keeps its session loop running.
TEST(Lifecycle, MajorityKilledAtOnceLeavesTheSurvivorPartitioned) {
    const auto scene = make_scene(3, 10);
    const SessionConfig cfg = lone_config(3, 8, 1024);
    Cluster cluster(scene, cfg, {20000, 4000}, 23);
    cluster.run_frames(200);
    cluster.kill(1);
    cluster.kill(2);
    cluster.run([](const Cluster&) { return false; }, 10'000'000);
    const Client& survivor = *cluster.clients[0];
    ASSERT_EQ(survivor.session->phase(), SessionPhase::Running) << survivor.session->failure();
    EXPECT_TRUE(survivor.session->partitioned());
    ASSERT_EQ(events_of(survivor, Kind::Partitioned).size(), 1u);
    EXPECT_LE(events_of(survivor, Kind::Partitioned)[0]->frame, survivor.session->confirmed_frame());
    EXPECT_TRUE(events_of(survivor, Kind::Disconnected).empty());
    for (PlayerId p : {1u, 2u}) EXPECT_EQ(survivor.session->slot_state(p), SlotState::Running) << "slot " << p;
    EXPECT_LT(survivor.session->confirmed_frame(), 220u);
}

// Alone from frame 0 (the other slot absent, nobody joins for a long time), then a joiner comes:
// the owner played on past its queues' capacity, and serves the joiner as usual.
TEST(Lifecycle, AloneFromTheStartThenAJoinerComes) {
    const auto scene = make_scene(2, 10);
    SessionConfig cfg = real_config(2, 8);
    cfg.input_capacity = 64;
    cfg.absent_slots = 1u << 1;
    Cluster cluster(scene, cfg, {10000, 2000}, 31);
    cluster.kill(1);  // nobody runs slot 1 yet
    cluster.run_frames(1000, 60'000'000);
    cluster.settle(1000, 5'000'000);
    const Client& owner = *cluster.clients[0];
    ASSERT_EQ(owner.session->phase(), SessionPhase::Running) << owner.session->failure();
    EXPECT_GE(owner.session->confirmed_frame(), 1000u);
    Client& joiner = start_newcomer(cluster, scene, cfg, Role::Joiner, 1, 32);
    cluster.run_frames(1600, 60'000'000);
    cluster.settle(1600);
    ASSERT_EQ(joiner.session->phase(), SessionPhase::Running) << joiner.session->failure();
    EXPECT_EQ(owner.session->slot_state(1), SlotState::Running);
    expect_equal_at(cluster, 1600);
}

// A spectator follows the survivor; then the spectator goes too (it times out, which is no slot
// drop): the survivor is alone and plays on.
TEST(Lifecycle, LoneSurvivorOutlivesItsSpectator) {
    const auto scene = make_scene(2, 10);
    SessionConfig cfg = lone_config(2, 8, 64);
    cfg.max_spectators = 1;
    Cluster cluster(scene, cfg, {10000, 2000}, 37);
    cluster.run_frames(100);
    Client& spectator = start_newcomer(cluster, scene, cfg, Role::Spectator, 2, 1);
    cluster.run_frames(200, 30'000'000);
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running);
    cluster.kill(1);
    cluster.run_frames(400, 30'000'000);
    cluster.kill(2);
    cluster.run_frames(1200, 60'000'000);
    cluster.settle(1200, 5'000'000);
    const Client& survivor = *cluster.clients[0];
    ASSERT_EQ(survivor.session->phase(), SessionPhase::Running) << survivor.session->failure();
    EXPECT_FALSE(events_of(survivor, Kind::SpectatorJoined).empty());
    EXPECT_EQ(events_of(survivor, Kind::Disconnected).size(), 2u);  // the slot, then the spectator
    EXPECT_GE(survivor.session->confirmed_frame(), 1200u);
}

// The same with the peer alive but unreachable (every datagram between the two is lost from
// frame 200 on): each drops the other and plays on alone.
TEST(Lifecycle, BothSidesOfAPartitionPlayOn) {
    const auto scene = make_scene(2, 10);
    const SessionConfig cfg = lone_config(2, 8, 64);
    Cluster cluster(scene, cfg, {20000, 4000}, 29);
    cluster.run_frames(200);
    cluster.filter = [](PlayerId, PlayerId, const std::vector<std::uint8_t>&) { return false; };
    cluster.run_frames(1000, 60'000'000);
    cluster.settle(1000, 5'000'000);
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_GE(c.session->frame(), 1000u) << "client " << p;
        EXPECT_GE(c.session->confirmed_frame(), 1000u) << "client " << p;
        EXPECT_EQ(c.session->slot_state(p == 0 ? 1 : 0), SlotState::Disconnected) << "client " << p;
    }
}

// A loaded machine, in virtual time: each loaded client stops now and then for a while (no
// tick, no poll; what arrives meanwhile is taken at its arrival time), as a process the
// scheduler starves does. Stalls of 50..max_stall_us, every 0.2..1.2 s, from a seed.
class Load {
public:
    Load(std::set<PlayerId> loaded, std::uint64_t max_stall_us, std::uint64_t seed)
        : loaded_(std::move(loaded)), max_stall_us_(max_stall_us), rng_(seed) {}
    // Runs `cluster` until `until()` or for at most limit_us more, stalling the loaded clients.
    void run(Cluster& cluster, const std::function<bool()>& until, std::uint64_t limit_us) {
        const std::uint64_t end = cluster.now() + limit_us;
        while (!until() && cluster.now() <= end) {
            for (PlayerId p : loaded_) apply(cluster, p);
            cluster.step_event();
        }
    }
    // Every loaded client ticks again.
    void lift(Cluster& cluster) {
        for (PlayerId p : loaded_)
            if (!cluster.dead(p)) cluster.clients[p]->frozen = false;
        loaded_.clear();
    }
    std::uint64_t longest_stall_us() const { return longest_; }
    int stalls() const { return stalls_; }

private:
    void apply(Cluster& cluster, PlayerId p) {
        if (cluster.dead(p)) return;
        Client& c = *cluster.clients[p];
        auto& [next_stall, thaw] = at_[p];
        const std::uint64_t now = cluster.now();
        if (c.frozen && now >= thaw) {
            c.frozen = false;
            next_stall = now + 200'000 + rng_.below(1'000'001);
        } else if (!c.frozen && next_stall == 0) {
            next_stall = now + 200'000 + rng_.below(1'000'001);
        } else if (!c.frozen && now >= next_stall) {
            const std::uint64_t stall = 50'000 + rng_.below(max_stall_us_ - 50'000 + 1);
            c.frozen = true;
            thaw = now + stall;
            longest_ = std::max(longest_, stall);
            ++stalls_;
        }
    }
    std::set<PlayerId> loaded_;
    std::uint64_t max_stall_us_;
    sim::SplitMix64 rng_;
    std::map<PlayerId, std::pair<std::uint64_t, std::uint64_t>> at_;  // next stall, thaw
    std::uint64_t longest_ = 0;
    int stalls_ = 0;
};

// Whether every client in `ids` runs and shows `frame`.
bool all_at(const Cluster& cluster, std::initializer_list<PlayerId> ids, std::uint32_t frame) {
    for (PlayerId p : ids)
        if (cluster.clients[p]->session->frame() < frame) return false;
    return true;
}

// Issue 21, what was seen: "after a lockstep peer's kill -9 two survivors dropped each other and
// both hung (under load)". Three players in lockstep, 5 % loss and 40 ms of jitter; both
// survivors' ticks are irregular (each stalls up to 400 ms now and then), and survivor 1 is
// starved for starved_us just as slot 2 dies at frame 200. The survivors must drop slot 2 and
// only slot 2, on the same frame; neither may hang; both play on to frame 1,500 and confirm it
// with one checksum. With a 1 s starve this passes on the tree before issue 21 (1f05175) as
// well (so do random stalls alone, even up to 1.3 s): it guards, it did not catch. 1.2 s and
// more fail there (0 drops 1 too and hangs at frame 1,229), and failed on main: see below.
void lockstep_kill_under_load(std::uint64_t seed, std::uint64_t starved_us) {
    const auto scene = make_scene(3, 10);
    SessionConfig cfg = real_config(3, 0);
    cfg.interrupt_us = 500'000;  // lockroll live's kill cases: 1.5 s to a drop
    cfg.disconnect_us = 1'500'000;
    Cluster cluster(scene, cfg, {20000, 40000, 50000}, seed);
    Load load({0, 1}, 400'000, seed * 31 + 7);
    load.run(cluster, [&] { return all_at(cluster, {0, 1, 2}, 200); }, 60'000'000);
    ASSERT_TRUE(all_at(cluster, {0, 1, 2}, 200));
    cluster.kill(2);
    // Survivor 1 is starved just then (no tick, no poll).
    const std::uint64_t thaw = cluster.now() + starved_us;
    cluster.clients[1]->frozen = true;
    while (cluster.now() < thaw) cluster.step_event();
    cluster.clients[1]->frozen = false;
    constexpr std::uint32_t kLast = 1500;
    load.run(cluster, [&] { return all_at(cluster, {0, 1}, kLast); }, 120'000'000);
    load.lift(cluster);
    cluster.run_frames(kLast, 10'000'000);
    cluster.settle(kLast, 10'000'000);
    EXPECT_GT(load.stalls(), 20);
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_GE(c.session->frame(), kLast) << "client " << p << " hung";
        EXPECT_GE(c.session->confirmed_frame(), kLast) << "client " << p << " hung";
        const auto drops = events_of(c, Kind::Disconnected);
        ASSERT_EQ(drops.size(), 1u) << "client " << p;
        EXPECT_EQ(drops[0]->peer, 2u) << "client " << p << " dropped a survivor";
        EXPECT_TRUE(events_of(c, Kind::Kicked).empty()) << "client " << p;
        for (PlayerId s : {0u, 1u}) EXPECT_EQ(c.session->slot_state(s), SlotState::Running) << "client " << p << " slot " << s;
        EXPECT_EQ(c.session->slot_state(2), SlotState::Disconnected) << "client " << p;
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << p;
    }
    ASSERT_EQ(events_of(*cluster.clients[0], Kind::NeutralFrom).size(), 1u);
    ASSERT_EQ(events_of(*cluster.clients[1], Kind::NeutralFrom).size(), 1u);
    EXPECT_EQ(events_of(*cluster.clients[0], Kind::NeutralFrom)[0]->frame,
              events_of(*cluster.clients[1], Kind::NeutralFrom)[0]->frame);
    expect_equal_at(cluster, kLast);
}

TEST(Lifecycle, LockstepKillUnderLoadDropsOnlyTheDeadAndBothSurvivorsFinish) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        lockstep_kill_under_load(seed, 1'000'000);
        if (HasFatalFailure()) return;
    }
}

// The same with survivor 1 starved for 1.4 s of the 1.5 s timeout at the kill. It failed on
// main (67925ec, c2cee46) in 4 seeds of 5. Survivor 0 votes 1 gone while it is silent (the
// silence, with a random stall before and the link's delay, reaches 1.5 s), then hears it
// again and withdraws the vote; but a table carrying the vote reached 1 after 2 was dropped,
// where the view is two and the two-player rule made one vote a majority: 1 was Kicked ("1 of
// 2 players voted this slot gone") and failed, and 0 hung or dropped it later by the same rule.
// Two survivors of a three-player match ended apart -- the split issue 21 forbids (audit
// N1/T4). Fixed by the two-player rule as meant: each side of a view of two decides for itself,
// and the other's vote never drops its own slot (rollback/membership.h). On the tree before
// issue 21 (1f05175) it fails too: 0 drops 1 and hangs at frame 1,229.
TEST(Lifecycle, LockstepKillWithASurvivorStarvedAtTheKillDropsOnlyTheDead) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        lockstep_kill_under_load(seed, 1'400'000);
    }
}

}  // namespace
}  // namespace lockroll::rollback
