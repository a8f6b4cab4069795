// The session lifecycle in virtual time (docs/sessions.md): handshake, drops, rejoins, late
// joins, spectators and desync recovery, over the in-test lossy network. The same code runs
// between real processes in tests/net.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <initializer_list>
#include <set>
#include <string>
#include <utility>

#include "rollback/playing_alone.h"
#include "rollback/session.h"
#include "rollback/session_impl.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Client;
using testing::Cluster;
using testing::make_scene;
using testing::NetParams;
using testing::real_config;
using testing::start_newcomer;
using Kind = SessionEvent::Kind;


std::vector<const SessionEvent*> events_of(const Client& c, Kind k) {
    std::vector<const SessionEvent*> out;
    for (const SessionEvent& e : c.events)
        if (e.kind == k) out.push_back(&e);
    return out;
}


// Every client that takes part confirmed `frame` with the same checksum.
void expect_equal_at(const Cluster& cluster, std::uint32_t frame) {
    std::optional<std::uint64_t> first;
    int compared = 0;
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        if (!cluster.counts(i)) continue;
        const auto& c = *cluster.clients[i];
        const auto it = c.confirmed.find(frame);
        ASSERT_NE(it, c.confirmed.end()) << "client " << i << " never confirmed frame " << frame;
        if (!first) first = it->second;
        EXPECT_EQ(it->second, *first) << "client " << i << " differs at confirmed frame " << frame;
        ++compared;
    }
    EXPECT_GE(compared, 2);
}

TEST(Lifecycle, HandshakeMeasuresRttThenEveryoneStarts) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    cfg.auto_input_delay = true;
    Cluster cluster(scene, cfg, {40000, 5000}, 11);
    cluster.run_frames(300);
    cluster.settle(300);
    for (const auto& c : cluster.clients) {
        EXPECT_EQ(c->session->phase(), SessionPhase::Running);
        ASSERT_EQ(events_of(*c, Kind::Synchronized).size(), 1u);
        // 80-90 ms round trips: rollback's auto delay covers half the one-way time in frames.
        EXPECT_GE(c->session->input_delay(), 2);
        EXPECT_LE(c->session->input_delay(), 4);
        EXPECT_GT(c->session->rtt_us(c == cluster.clients[0] ? 1 : 0), 70000u);
        EXPECT_LT(c->session->rtt_us(c == cluster.clients[0] ? 1 : 0), 110000u);
    }
    expect_equal_at(cluster, 300);
    // The overlay's figures: ~85 ms ping with up to 10 ms of jitter both ways, a few hundred
    // bits per second each way, nobody far behind, a short send queue.
    const NetworkStats n = cluster.clients[0]->session->network_stats(1, cluster.now());
    EXPECT_GT(n.ping_us, 70000u);
    EXPECT_LT(n.ping_us, 110000u);
    EXPECT_GT(n.jitter_us, 0u);
    EXPECT_LT(n.jitter_us, 15000u);
    EXPECT_GT(n.kbps_sent, 1.0);
    EXPECT_LT(n.kbps_sent, 20.0);
    EXPECT_GT(n.kbps_received, 1.0);
    EXPECT_LE(std::abs(n.frames_behind), 4);
    EXPECT_LE(n.send_queue, 12u);
}

TEST(Lifecycle, MismatchedMatchIdIsRefusedOnBothSides) {
    const auto scene = make_scene(2, 4);
    Cluster cluster(scene, real_config(2, 8), {10000}, 3);
    // Client 1 belongs to another match.
    SessionConfig other = real_config(2, 8);
    other.match_id = 42;
    other.local_player = 1;
    cluster.start(1, scene, other, 77).catches_up = false;
    cluster.run([](const Cluster&) { return false; }, 2'000'000);
    for (const auto& c : cluster.clients) {
        EXPECT_EQ(c->session->phase(), SessionPhase::Failed);
        EXPECT_NE(c->session->failure().find("match id"), std::string::npos) << c->session->failure();
        ASSERT_FALSE(events_of(*c, Kind::Refused).empty());
        for (const SessionEvent* e : events_of(*c, Kind::Refused)) EXPECT_EQ(e->reason, SessionEvent::Reason::MatchId) << e->detail;
        ASSERT_EQ(events_of(*c, Kind::Failed).size(), 1u);
        EXPECT_EQ(events_of(*c, Kind::Failed)[0]->reason, SessionEvent::Reason::MatchId);
        EXPECT_GT(c->session->foreign_packets(), 0u);
        EXPECT_EQ(c->session->frame(), 0u);
    }
}

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
        EXPECT_LT(events_of(c, Kind::Disconnected)[0]->at_us - killed_at, cfg.disconnect_us + 200'000);
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
        EXPECT_LT(events_of(survivor, Kind::Disconnected)[0]->at_us, restarted_at + 500'000) << "survivor " << p;
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
    restart_after(Role::Joiner, 1'000'000, "rejoining, by 2 of 3 votes", SessionEvent::Reason::Rejoining, 3);
}
TEST(Lifecycle, RestartAsPlayerOfOneOfThreeIsDroppedByTheTwoVotesThenRejoins) {
    restart_after(Role::Player, 300'000, "restarted, by 2 of 3 votes", SessionEvent::Reason::Restarted, 3);
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
    std::vector<std::uint8_t> hello_bytes;  // slot 1's own first hello to peer 0
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (from == 1 && to == 0 && hello_bytes.empty() && !b.empty() && b[0] == static_cast<std::uint8_t>(MessageKind::Hello))
            hello_bytes = b;
        return true;
    };
    cluster.run_frames(200);
    HelloMessage h;
    ASSERT_EQ(decode(hello_bytes, h), nullptr);
    h.role = Role::Joiner;
    h.incarnation += 12345;
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


TEST(Lifecycle, KillAndRejoinLockstep) { kill_and_rejoin(0); }

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

// Between real processes a survivor's welcome can reach the joiner only after the joiner has
// loaded its snapshot and runs (its connection came up late: the survivor was still timing out
// its reconnects to the dead process). The survivor's welcome reaches a joiner that already
// runs: the two must still start exchanging inputs, and nobody is dropped. Since issue 21's
// strict vetting the joiner loads only once a majority of the view (here the owner and the
// survivor) confirmed its snapshot's checksum, each on its own connection, so the survivor's
// answer must have reached it: what comes late is only its welcome. (Before, nothing at all
// passed between the two until the joiner ran, and it loaded on the owner's word alone; a
// joiner cut off from the survivor that long is AJoinerCutOffFromTheMajorityIsToldAndWaits.)
TEST(Lifecycle, SurvivorReachedOnlyAfterTheJoinerRuns) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    cfg.disconnect_us = 1'500'000;
    Cluster cluster(scene, cfg, {10000, 2000}, 17);
    cluster.run_frames(200);
    cluster.kill(2);
    cluster.run_frames(400, 60'000'000);
    SessionConfig again = cfg;
    again.local_player = 2;
    again.role = Role::Joiner;
    bool started = false;
    // Client 1's welcomes do not reach the new slot-2 process until the joiner runs.
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        const bool welcome = from == 1 && to == 2 && !b.empty() && b[0] == static_cast<std::uint8_t>(MessageKind::Welcome);
        return !(welcome && started && cluster.clients[2]->session->phase() != SessionPhase::Running);
    };
    Client& joiner = cluster.start(2, scene, again, 999);
    started = true;
    cluster.run_frames(1000, 60'000'000);
    cluster.settle(1000);
    ASSERT_EQ(joiner.session->phase(), SessionPhase::Running) << joiner.session->failure();
    ASSERT_EQ(events_of(joiner, Kind::SnapshotLoaded).size(), 1u);
    EXPECT_EQ(events_of(joiner, Kind::SnapshotLoaded)[0]->peer, 0u) << "the owner serves the joiner";
    EXPECT_NE(events_of(joiner, Kind::SnapshotLoaded)[0]->detail.find(": 2 agree, 0 differ, 2 needed"), std::string::npos)
        << events_of(joiner, Kind::SnapshotLoaded)[0]->detail;
    EXPECT_TRUE(events_of(joiner, Kind::Kicked).empty());
    // The scene this test is about did happen: slot 1's first welcome came after the load.
    const auto from_1 = std::find_if(joiner.events.begin(), joiner.events.end(),
                                     [](const SessionEvent& e) { return e.kind == Kind::Synchronizing && e.peer == 1; });
    ASSERT_NE(from_1, joiner.events.end());
    EXPECT_GT(from_1->at_us, events_of(joiner, Kind::SnapshotLoaded)[0]->at_us);
    for (PlayerId p : {0u, 1u}) {
        EXPECT_EQ(cluster.clients[p]->session->slot_state(2), SlotState::Running) << "client " << p;
        EXPECT_EQ(events_of(*cluster.clients[p], Kind::Disconnected).size(), 1u) << "only the kill, client " << p;
    }
    expect_equal_at(cluster, 1000);
}

// The owner itself (slot 0, which writes absent slots' inputs) dies while slot 3 is absent: the
// next lowest running slot takes both streams over from where the peers agree, and a joiner
// into slot 0 is served by the new owner.
TEST(Lifecycle, OwnerDiesAndTheNextSlotTakesOver) {
    const auto scene = make_scene(4, 10);
    SessionConfig cfg = real_config(4, 8);
    cfg.absent_slots = 1u << 3;
    Cluster cluster(scene, cfg, {20000, 10000, 100000}, 21);
    cluster.kill(3);
    cluster.run_frames(240);
    cluster.kill(0);
    cluster.run_frames(900, 60'000'000);
    for (PlayerId p : {1u, 2u}) {
        const Client& c = *cluster.clients[p];
        EXPECT_EQ(c.session->slot_state(0), SlotState::Disconnected);
        EXPECT_EQ(c.session->slot_state(3), SlotState::Absent);
    }
    EXPECT_EQ(events_of(*cluster.clients[1], Kind::NeutralFrom).back()->frame,
              events_of(*cluster.clients[2], Kind::NeutralFrom).back()->frame);
    cluster.settle(900);
    expect_equal_at(cluster, 900);
    SessionConfig join = cfg;
    join.role = Role::Joiner;
    join.local_player = 0;
    Client& joiner = cluster.start(0, scene, join, 5);
    cluster.run_frames(1300, 60'000'000);
    cluster.settle(1300);
    EXPECT_EQ(joiner.session->phase(), SessionPhase::Running) << joiner.session->failure();
    expect_equal_at(cluster, 1300);
}

TEST(Lifecycle, LateJoinIntoAbsentSlotAndSpectator) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    cfg.absent_slots = 1u << 2;
    cfg.max_spectators = 1;
    Cluster cluster(scene, cfg, {25000, 5000}, 8);
    cluster.kill(2);  // nobody runs slot 2 yet
    cluster.run_frames(150);
    SessionConfig spec = cfg;
    spec.role = Role::Spectator;
    spec.local_player = 3;
    Client& spectator = cluster.start(3, scene, spec, 1);
    cluster.run_frames(300, 30'000'000);
    SessionConfig join = cfg;
    join.role = Role::Joiner;
    join.local_player = 2;
    Client& joiner = cluster.start(2, scene, join, 2);
    cluster.run_frames(700, 60'000'000);
    cluster.settle(700);
    EXPECT_EQ(spectator.session->phase(), SessionPhase::Running);
    EXPECT_EQ(joiner.session->phase(), SessionPhase::Running);
    EXPECT_FALSE(events_of(*cluster.clients[0], Kind::SpectatorJoined).empty());
    expect_equal_at(cluster, 700);
    // Before the join, slot 2 was absent from frame 0 on every peer.
    EXPECT_EQ(events_of(*cluster.clients[1], Kind::NeutralFrom)[0]->frame, 0u);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().malformed_packets, 0u);
}

void rejoin_when_dropped(Cluster& cluster) {
    cluster.before_tick = [](PlayerId, Client& c) {
        if (c.session->phase() != SessionPhase::Failed || !c.session->can_rejoin()) return;
        for (SessionEvent e; c.session->next_event(e);) c.events.push_back(e);  // the kick, first
        ASSERT_TRUE(c.session->restart_as_joiner());
        c.catches_up = true;
    };
}

TEST(Lifecycle, CorruptedSnapshotChunkIsRejectedAndAskedAgain) {
    const auto scene = make_scene(2, 30);
    SessionConfig cfg = real_config(2, 8);
    cfg.absent_slots = 1u << 1;
    Cluster cluster(scene, cfg, {10000}, 4);
    cluster.kill(1);
    cluster.run_frames(100);
    int corrupted = 0;
    cluster.filter = [&](PlayerId from, PlayerId, const std::vector<std::uint8_t>& b) {
        if (from == 0 && !b.empty() && b[0] == static_cast<std::uint8_t>(MessageKind::SnapshotChunk) && corrupted == 0) {
            ++corrupted;
            auto& bytes = const_cast<std::vector<std::uint8_t>&>(b);
            bytes.back() ^= 0x5A;
        }
        return true;
    };
    SessionConfig join = cfg;
    join.role = Role::Joiner;
    join.local_player = 1;
    Client& joiner = cluster.start(1, scene, join, 3);
    cluster.run_frames(400, 30'000'000);
    cluster.settle(400);
    EXPECT_EQ(corrupted, 1);
    ASSERT_EQ(events_of(joiner, Kind::SnapshotRejected).size(), 1u);
    EXPECT_NE(events_of(joiner, Kind::SnapshotRejected)[0]->detail.find("hash mismatch"), std::string::npos);
    EXPECT_EQ(events_of(joiner, Kind::SnapshotLoaded).size(), 1u);
    expect_equal_at(cluster, 400);
}

// Issue 21, the 16-minute soak: a joiner that cannot load (every snapshot it gets is refused)
// keeps talking, so silence never drops it, and every player waited at its handoff frame for
// good. Its handoff lapses instead: a slot handed over whose own stream has not started within
// disconnect_us is voted gone and dropped (the stall bounded as any drop's), the slot stays
// neutral, and the joiner, refused as dropped, asks again and gets in once it can load.
TEST(Lifecycle, AJoinerThatCannotLoadLapsesAndTheOthersPlayOn) {
    const auto joins_of = [](const Client& c) { return events_of(c, Kind::Joined).size(); };
    const auto scene = make_scene(3, 20);
    const SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {30000, 8000, 20000}, 9);
    rejoin_when_dropped(cluster);
    cluster.run_frames(200);
    cluster.kill(2);
    cluster.run_frames(600, 60'000'000);
    ASSERT_EQ(cluster.clients[0]->session->slot_state(2), SlotState::Disconnected);
    bool refuse = true;  // every chunk the joiner gets is damaged: it never loads
    cluster.filter = [&](PlayerId, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (refuse && to == 2 && !b.empty() && b[0] == static_cast<std::uint8_t>(MessageKind::SnapshotChunk))
            const_cast<std::vector<std::uint8_t>&>(b).back() ^= 0x5A;
        return true;
    };
    SessionConfig again = cfg;
    again.local_player = 2;
    again.role = Role::Joiner;
    Client& joiner = cluster.start(2, scene, again, 999);
    const std::uint64_t joined_at = cluster.now();
    const std::uint32_t before = cluster.clients[0]->session->frame();
    cluster.run([](const Cluster&) { return false; }, 6 * cfg.disconnect_us);
    EXPECT_FALSE(events_of(joiner, Kind::SnapshotRejected).empty());
    EXPECT_TRUE(events_of(joiner, Kind::SnapshotLoaded).empty());
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_FALSE(events_of(c, Kind::Joined).empty()) << "client " << p;
        // Dropped again once its handoff lapsed, and the match went on.
        const auto drops = events_of(c, Kind::Disconnected);
        ASSERT_GE(drops.size(), 2u) << "client " << p;
        EXPECT_NE(drops[1]->detail.find("handoff lapsed"), std::string::npos) << drops[1]->detail;
        EXPECT_LT(drops[1]->at_us - joined_at, 2 * cfg.disconnect_us) << "client " << p;
        // 30 s: handed over, lapsed after 5 s, not again for 10 s, lapsed again: it stalled the
        // others for about a third of the time (before, for good at the first handoff).
        EXPECT_GT(c.session->frame(), before + 60 * 30 / 2) << "client " << p;
        EXPECT_LE(joins_of(c), 3u) << "client " << p;
    }
    // It can load now: it asks again and plays.
    refuse = false;
    cluster.run_frames(cluster.clients[0]->session->frame() + 600, 120'000'000);
    cluster.settle(cluster.clients[0]->session->frame());
    EXPECT_EQ(cluster.clients[2]->session->phase(), SessionPhase::Running);
    EXPECT_FALSE(events_of(*cluster.clients[2], Kind::SnapshotLoaded).empty());
    EXPECT_EQ(cluster.clients[0]->session->slot_state(2), SlotState::Running);
    EXPECT_EQ(cluster.clients[1]->session->slot_state(2), SlotState::Running);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
}

// Issue 21: a joiner loads only on a majority's checksum. Cut off from survivor 1 (nothing passes
// between them), it hears only the owner, which serves it: that is one of the view's three
// running processes, no majority. Before, the owner's own answer with slot 1 silent was enough
// at the vetting deadline and it loaded. Now each offer is rejected at the deadline naming the
// silent peer (never a silent hang), its handoff lapses and the pair plays on, and once the cut
// heals it asks again and loads on the owner's and slot 1's word.
TEST(Lifecycle, AJoinerCutOffFromTheMajorityIsToldAndWaits) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {10000, 2000}, 17);
    rejoin_when_dropped(cluster);
    cluster.run_frames(200);
    cluster.kill(2);
    cluster.run_frames(400, 60'000'000);
    ASSERT_EQ(cluster.clients[0]->session->slot_state(2), SlotState::Disconnected);
    bool cut = true;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return !(cut && ((from == 1 && to == 2) || (from == 2 && to == 1)));
    };
    SessionConfig again = cfg;
    again.local_player = 2;
    again.role = Role::Joiner;
    cluster.start(2, scene, again, 999);
    const std::uint32_t before = cluster.clients[0]->session->frame();
    cluster.run([](const Cluster&) { return false; }, 3 * cfg.disconnect_us);
    {
        const Client& joiner = *cluster.clients[2];
        EXPECT_TRUE(events_of(joiner, Kind::SnapshotLoaded).empty()) << events_of(joiner, Kind::SnapshotLoaded)[0]->detail;
        const auto rejected = events_of(joiner, Kind::SnapshotRejected);
        ASSERT_FALSE(rejected.empty()) << "the joiner says why it does not load";
        EXPECT_EQ(rejected[0]->peer, 0u);
        EXPECT_NE(rejected[0]->detail.find("cut off from a majority of the view: no answer in time from peer 1"),
                  std::string::npos)
            << rejected[0]->detail;
        for (PlayerId p : {0u, 1u})
            EXPECT_GT(cluster.clients[p]->session->frame(), before + 60 * 3 * cfg.disconnect_us / 1'000'000 / 3)
                << "client " << p << " plays on";
    }
    cut = false;
    const std::uint32_t end = cluster.clients[0]->session->frame() + 600;
    cluster.run_frames(end, 120'000'000);
    cluster.settle(end);
    const Client& joiner = *cluster.clients[2];
    ASSERT_EQ(joiner.session->phase(), SessionPhase::Running) << joiner.session->failure();
    const auto loaded = events_of(joiner, Kind::SnapshotLoaded);
    ASSERT_EQ(loaded.size(), 1u);
    EXPECT_NE(loaded[0]->detail.find(": 2 agree, 0 differ, 2 needed"), std::string::npos) << loaded[0]->detail;
    for (PlayerId p : {0u, 1u}) EXPECT_EQ(cluster.clients[p]->session->slot_state(2), SlotState::Running);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
    expect_equal_at(cluster, end);
}

// `players` players, one recovery allowed; client `odd`'s body is kicked at frame 150, so it is
// the odd one. Runs to frame 600, settled, then hands the cluster and the body to `check`.
void run_injected_desync(int players, PlayerId odd, const std::function<void(const Cluster&, std::uint32_t body)>& check) {
    const auto scene = make_scene(players, 20);
    SessionConfig cfg = real_config(players, 8);
    cfg.max_recoveries = 1;
    Cluster cluster(scene, cfg, {20000, 4000}, 6);
    cluster.run_frames(100);
    const std::uint32_t body = cluster.clients[odd]->sim.body_id(5);
    ASSERT_EQ(cluster.clients[odd]->session->inject_fault(150, body, 0, 20), "");
    cluster.run_frames(600, 60'000'000);
    cluster.settle(600);
    check(cluster, body);
    expect_equal_at(cluster, 600);
}

TEST(Lifecycle, InjectedDesyncIsNamedAndTheOddOneRecovers) {
    run_injected_desync(3, 2, [](const Cluster& cluster, std::uint32_t body) {
        const Client& odd = *cluster.clients[2];
        ASSERT_FALSE(odd.reports.empty());
        EXPECT_EQ(odd.reports[0].frame, 150u);
        EXPECT_EQ(odd.reports[0].body_id, body);
        EXPECT_EQ(odd.session->recoveries(), 1);
        ASSERT_EQ(events_of(odd, Kind::DesyncRecovered).size(), 1u);
        EXPECT_EQ(events_of(odd, Kind::DesyncRecovered)[0]->reason, SessionEvent::Reason::Majority);
        for (const SessionEvent* e : events_of(odd, Kind::DesyncDetected))
            EXPECT_EQ(e->reason, SessionEvent::Reason::ChecksumMismatch);
        EXPECT_EQ(cluster.clients[0]->session->recoveries(), 0);
        EXPECT_EQ(cluster.clients[1]->session->recoveries(), 0);
    });
}

// A desync is reported once (issue 21: one event stream): one `DesyncDetected` per peer whose
// confirmed checksums differ, the same (peer, frame) the observer's on_desync callback gets; that
// this peer was the minority is said by its `DesyncRecovered`. Before, the odd one emitted a
// second DesyncDetected, naming the peer it reloads from, when it decided to reload.
TEST(Lifecycle, ADesyncIsReportedOncePerPeerAndTheRecoveryNamesTheMinority) {
    run_injected_desync(3, 2, [](const Cluster& cluster, std::uint32_t) {
        for (PlayerId id = 0; id < 3; ++id) {
            const Client& c = *cluster.clients[id];
            const auto detected = events_of(c, Kind::DesyncDetected);
            const std::vector<PlayerId> expected = id == 2 ? std::vector<PlayerId>{0, 1} : std::vector<PlayerId>{2};
            ASSERT_EQ(detected.size(), expected.size()) << "client " << id;
            ASSERT_EQ(c.desyncs.size(), expected.size()) << "client " << id;
            std::set<PlayerId> peers;
            for (std::size_t i = 0; i < detected.size(); ++i) {
                peers.insert(detected[i]->peer);
                EXPECT_EQ(detected[i]->peer, c.desyncs[i].peer) << "client " << id << ": the callback is the same event";
                EXPECT_EQ(detected[i]->frame, c.desyncs[i].frame) << "client " << id;
            }
            EXPECT_EQ(peers, std::set<PlayerId>(expected.begin(), expected.end())) << "client " << id;
        }
        const Client& odd = *cluster.clients[2];
        const auto recovered = events_of(odd, Kind::DesyncRecovered);
        ASSERT_EQ(recovered.size(), 1u);
        EXPECT_NE(recovered[0]->detail.find("minority at frame " + std::to_string(odd.desyncs[0].frame) +
                                            ", by the biggest group, 2 of 3; reloaded peer 0's"),
                  std::string::npos)
            << recovered[0]->detail;
    });
}

// Issue 21 (Q7): two players that disagree have no majority; the tie rule (two_player_keep)
// decides, and the reloading side's DesyncRecovered says so, not "the minority". Before it read
// "this peer was in the minority at frame F (or a tie's other side: two_player_keep)".
TEST(Lifecycle, TwoPlayerDesyncRecoveryNamesTheTieRule) {
    run_injected_desync(2, 1, [](const Cluster& cluster, std::uint32_t) {
        const Client& odd = *cluster.clients[1];
        EXPECT_EQ(odd.session->recoveries(), 1);
        EXPECT_EQ(cluster.clients[0]->session->recoveries(), 0);
        const auto recovered = events_of(odd, Kind::DesyncRecovered);
        ASSERT_EQ(recovered.size(), 1u);
        ASSERT_FALSE(odd.desyncs.empty());
        EXPECT_EQ(recovered[0]->reason, SessionEvent::Reason::TieRule);
        EXPECT_EQ(recovered[0]->detail, "this peer was on a tie's other side at frame " + std::to_string(odd.desyncs[0].frame) +
                                            ", by no majority (a tie, 1 against 1): the tie rule (two_player_keep: "
                                            "lowest_slot) keeps slot 0's group; reloaded peer 0's confirmed frame " +
                                            std::to_string(recovered[0]->frame));
    });
}

// A snapshot request is a claim. "Recover" from a peer whose confirmed checksums agree with
// ours is not answered (before: every one was, each a whole snapshot for a few bytes, about 90x
// amplification); during a real desync a flood of requests gets at most one fresh snapshot a
// second (before: one every 300 ms), and the odd one still recovers.
TEST(Lifecycle, RecoveryRequestsAreAnsweredOnlyDuringADesync) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    cfg.max_recoveries = 1;
    Cluster cluster(scene, cfg, {20000, 4000}, 6);
    cluster.run_frames(100);
    std::vector<std::uint8_t> request;
    encode(SnapshotRequestMessage{TransferReason::Recover, 0, 0}, request);
    std::set<std::uint32_t> offers;  // fresh transfers client 0 offered to peer 1
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        SnapshotOfferMessage o;
        if (from == 0 && to == 1 && decode(b, o) == nullptr) offers.insert(o.transfer_id);
        return true;
    };
    bool flood = true;
    cluster.before_tick = [&](PlayerId id, Client&) {
        if (id == 1 && flood) cluster.clients[0]->session->receive(1, request, cluster.now());
    };
    cluster.run_frames(400, 60'000'000);
    EXPECT_TRUE(offers.empty()) << offers.size() << " snapshots offered with no desync open";
    EXPECT_GE(cluster.clients[0]->session->stats().peers[1].ignored_packets, 250u);
    cluster.settle(400);  // a frame is confirmed once a majority holds our inputs for it: a round trip
    expect_equal_at(cluster, 400);

    // Peer 1 really desyncs at frame 450 and keeps flooding for 10 s of play.
    const std::uint32_t body = cluster.clients[1]->sim.body_id(5);
    ASSERT_EQ(cluster.clients[1]->session->inject_fault(450, body, 0, 20), "");
    cluster.run_frames(1000, 60'000'000);
    flood = false;
    cluster.run_frames(1200, 60'000'000);
    cluster.settle(1200);
    EXPECT_GE(offers.size(), 1u);
    EXPECT_LE(offers.size(), 12u) << "fresh recovery snapshots for ~10 s of requests";
    EXPECT_EQ(events_of(*cluster.clients[1], Kind::DesyncRecovered).size(), 1u);
    expect_equal_at(cluster, 1200);
}

// A peer that falls silent is not assumed to run on for ever: a minute after peer 1 died (never
// dropped: disconnect_us 0), the survivor's estimate of how far behind it is stays within the
// interrupt time plus delay and window. Before, it extrapolated the silence: -3,6xx frames here,
// -53,768 in a long real-process run.
TEST(Lifecycle, SilentPeerIsNotEstimatedToRunOn) {
    const auto scene = make_scene(2, 4);
    SessionConfig cfg = real_config(2, 8);
    cfg.disconnect_us = 0;
    Cluster cluster(scene, cfg, {10000}, 9);
    cluster.run_frames(120);
    cluster.kill(1);
    cluster.run([](const Cluster&) { return false; }, 60'000'000);
    const NetworkStats n = cluster.clients[0]->session->network_stats(1, cluster.now());
    EXPECT_TRUE(n.interrupted);
    const int interrupt_frames = static_cast<int>(cfg.interrupt_us * 60 / 1'000'000);
    const int slack = interrupt_frames + cfg.input_delay + cfg.prediction_window + 2;
    EXPECT_GE(n.frames_behind, -slack);
    EXPECT_LE(n.frames_behind, slack);
}

// One clock 1 % fast, one 5 % slow: time sync holds the fast ones back (they wait, the slow one
// never stalls for long), nobody drifts apart by more than delay + window, and all end equal.
TEST(Lifecycle, ClocksOnePercentFastAndFivePercentSlow) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {30000, 5000}, 17);
    cluster.clients[1]->drift_ppm = 10000;
    cluster.clients[2]->drift_ppm = -50000;
    std::int64_t widest = 0;
    cluster.before_tick = [&](PlayerId, Client&) {
        std::int64_t lo = INT64_MAX, hi = 0;
        for (const auto& c : cluster.clients) {
            lo = std::min<std::int64_t>(lo, c->session->frame());
            hi = std::max<std::int64_t>(hi, c->session->frame());
        }
        if (lo > 60) widest = std::max(widest, hi - lo);
    };
    cluster.run_frames(1800, 120'000'000);
    cluster.settle(1800);
    expect_equal_at(cluster, 1800);
    EXPECT_LE(widest, cfg.input_delay + cfg.prediction_window);
    // The 5 % slow client sets the pace: the others wait for it, it does not wait for them.
    EXPECT_GT(cluster.clients[0]->session->stats().time_sync_waits, 0u);
    EXPECT_GT(cluster.clients[1]->session->stats().time_sync_waits, 0u);
    for (const auto& c : cluster.clients) {
        const auto& st = c->session->stats();
        const double stalls = static_cast<double>(st.stall_ticks) / static_cast<double>(st.ticks);
        std::printf("client %u: drift %lld ppm, %.2f %% of ticks stalled, %llu time-sync waits\n",
                    c->session->config().local_player, static_cast<long long>(c->drift_ppm), 100 * stalls,
                    static_cast<unsigned long long>(st.time_sync_waits));
        // Waiting a tick now and then instead of running into the window.
        EXPECT_LT(stalls, 0.01);
    }
}

// Real-time loops (net/peer_runner) follow time sync by lengthening the next tick by the
// session's tick_stretch_ppm, up to a cap, instead of skipping ticks. Clocks 1 % fast and 5 % slow
// are 6.3 % apart: capped at 5 % (GGRS's figure, the old cap) the faster clients cannot slow down
// enough and stall at their window now and then; at 10 % (the session's and the runner's cap
// now) nobody stalls once running. tests/harness/live_faults_test.sh runs the same with real
// processes.
TEST(Lifecycle, StretchedTicksFollowClocksSixPercentApart) {
    const auto stalls_with_cap = [](int cap_ppm) {
        const auto scene = make_scene(3, 20);
        SessionConfig cfg = real_config(3, 8);
        Cluster cluster(scene, cfg, {30000, 5000}, 17);
        cluster.obey_time_sync = false;  // no skipped ticks: stretched ones only
        cluster.clients[1]->drift_ppm = 10000;
        cluster.clients[2]->drift_ppm = -50000;
        std::uint64_t stalls = 0;
        cluster.before_tick = [&](PlayerId, Client& c) {
            const int ppm = std::min(c.last_advance.tick_stretch_ppm, cap_ppm);
            c.start_offset_us += 16667u * static_cast<std::uint64_t>(ppm) / 1000000u;
            if (c.session->running() && c.session->frame() > 60 && c.ticks > 1 && !c.last_advance.advanced) ++stalls;
        };
        cluster.run_frames(1800, 120'000'000);
        cluster.settle(1800);
        expect_equal_at(cluster, 1800);
        std::printf("stretch capped at %d ppm: %llu stalled ticks after frame 60\n", cap_ppm,
                    static_cast<unsigned long long>(stalls));
        return stalls;
    };
    EXPECT_EQ(stalls_with_cap(100000), 0u);
    EXPECT_GT(stalls_with_cap(50000), 0u);  // the control: the old cap is too small
}

// Issue 21, "any peer's word drops any player": peer 2 rewrites the slot table of its input
// messages (adding one to every message) to claim that slot 1, which plays fine, was dropped in
// a newer epoch. Sent to peer 0 alone (and in the variant to both others), it is one vote of
// three: slot 1 stays everywhere, all three confirm equal checksums, and the receivers count
// the claim as unheeded.
void forged_slot_table(bool to_both) {
    const auto scene = make_scene(3, 10);
    const SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {15000, 3000}, 41);
    cluster.run_frames(120);
    int forged = 0;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (from != 2 || (to != 0 && !(to_both && to == 1)) || b.empty() || (b[0] & 0x0F) != 1) return true;
        InputMessage m;
        if (decode(b, cfg.input_size, m) != nullptr) return true;
        if (!m.has_extension) {
            // An honest steady peer sends its table only when it changes; a forger sends one
            // whenever it likes (counts 0: it claims to lag, which costs the others relays).
            m.has_extension = true;
            for (std::uint8_t s = 0; s < 3; ++s) m.slots.push_back({s, SlotState::Running, 0, 0});
        }
        for (SlotEntry& e : m.slots) {
            if (e.slot != 1) continue;
            e.state = SlotState::Disconnected;
            e.epoch = static_cast<std::uint8_t>(e.epoch + 3);
            ++forged;
        }
        auto& bytes = const_cast<std::vector<std::uint8_t>&>(b);
        bytes.clear();
        encode(m, cfg.input_size, bytes);
        return true;
    };
    cluster.run_frames(900, 60'000'000);  // ten seconds of forgeries, twice the drop timeout
    cluster.settle(900);
    EXPECT_GT(forged, 10);
    for (PlayerId p : {0u, 1u, 2u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_EQ(c.session->slot_state(1), SlotState::Running) << "client " << p;
        EXPECT_TRUE(events_of(c, Kind::Disconnected).empty()) << "client " << p;
        EXPECT_TRUE(events_of(c, Kind::Kicked).empty()) << "client " << p;
        EXPECT_TRUE(events_of(c, Kind::Partitioned).empty()) << "client " << p;
    }
    EXPECT_GT(cluster.clients[0]->session->stats().drop_votes_unheeded, 0u);
    if (to_both) {
        EXPECT_GT(cluster.clients[1]->session->stats().drop_votes_unheeded, 0u);
    }
    expect_equal_at(cluster, 900);
}

TEST(Lifecycle, ForgedSlotTableDropsNobody) { forged_slot_table(false); }
TEST(Lifecycle, ForgedSlotTableToBothOthersDropsNobody) { forged_slot_table(true); }

// Every datagram between `side` and the rest is lost while `cut` is set.
void split(Cluster& cluster, std::set<PlayerId> side, const bool& cut) {
    cluster.filter = [side = std::move(side), &cut](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return !cut || side.count(from) == side.count(to);
    };
}

// For every frame both clients confirmed, the same checksum.
void expect_no_disagreement(const Client& a, const Client& b, int& compared) {
    for (const auto& [frame, checksum] : a.confirmed) {
        const auto it = b.confirmed.find(frame);
        if (it == b.confirmed.end()) continue;
        ++compared;
        ASSERT_EQ(it->second, checksum) << "confirmed frame " << frame;
    }
}

// A client whose session the others dropped starts again as a joiner of its slot, as
// net::PeerRunner and the in-process match do (Session::restart_as_joiner), and catches up.

// Issue 21, "split matches": three players, {0, 1} and {2} cannot hear each other for 10 s. The
// pair is a majority: it drops 2 and plays on. 2 drops nobody, says Partitioned and never
// confirms a frame the pair confirmed differently. Healed, it hears it was dropped (a majority
// says so) and is Kicked; started again as a joiner of its slot it rejoins the pair's view by
// a snapshot they both vouch for, catches up without the pair pausing, and all three end on
// one checksum. (window: rollback or lockstep; the one's clock runs drift_ppm fast; the cut
// comes at cut_frame.)
void split_two_one(int window, std::uint64_t seed, std::int64_t drift_ppm, std::uint32_t cut_frame) {
    const auto scene = make_scene(3, 10);
    const SessionConfig cfg = real_config(3, window);
    Cluster cluster(scene, cfg, {15000, 3000}, seed);
    cluster.clients[2]->drift_ppm = drift_ppm;
    cluster.run_frames(cut_frame);
    bool cut = true;
    split(cluster, {2}, cut);
    cluster.run([](const Cluster&) { return false; }, 10'000'000);
    const Client& lone = *cluster.clients[2];
    ASSERT_EQ(lone.session->phase(), SessionPhase::Running) << lone.session->failure();
    EXPECT_TRUE(lone.session->partitioned());
    ASSERT_EQ(events_of(lone, Kind::Partitioned).size(), 1u);
    EXPECT_TRUE(events_of(lone, Kind::Disconnected).empty()) << "the minority drops nobody";
    for (PlayerId p : {0u, 1u}) EXPECT_EQ(lone.session->slot_state(p), SlotState::Running);
    const std::uint32_t partitioned_at = events_of(lone, Kind::Partitioned)[0]->frame;
    const std::uint64_t stalled_before[2] = {cluster.clients[0]->session->stats().stall_time_us,
                                             cluster.clients[1]->session->stats().stall_time_us};
    cut = false;
    rejoin_when_dropped(cluster);
    cluster.run_frames(1200, 60'000'000);
    cluster.settle(1200);
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_EQ(c.session->slot_state(2), SlotState::Running) << "client " << p << ": slot 2 did not rejoin";
        EXPECT_EQ(events_of(c, Kind::Disconnected).size(), 1u) << "client " << p;
        EXPECT_FALSE(events_of(c, Kind::Joined).empty()) << "client " << p;
        EXPECT_TRUE(events_of(c, Kind::Partitioned).empty()) << "client " << p;
        EXPECT_GE(c.session->confirmed_frame(), 1200u) << "client " << p;
        // Nobody paused for the rejoin (a stall is a tick that could not step).
        EXPECT_LT(c.session->stats().stall_time_us - stalled_before[p], 100'000u) << "client " << p;
    }
    EXPECT_EQ(events_of(*cluster.clients[0], Kind::NeutralFrom)[0]->frame,
              events_of(*cluster.clients[1], Kind::NeutralFrom)[0]->frame);
    // The lone one learned it was dropped, rejoined by one vetted snapshot of a frame the pair
    // confirmed after the heal, and never confirmed anything else than the pair.
    EXPECT_EQ(events_of(lone, Kind::Kicked).size(), 1u);
    EXPECT_TRUE(events_of(lone, Kind::Disconnected).empty());
    ASSERT_EQ(lone.session->phase(), SessionPhase::Running) << lone.session->failure();
    EXPECT_EQ(lone.session->config().role, Role::Joiner);
    ASSERT_EQ(events_of(lone, Kind::SnapshotLoaded).size(), 1u);
    EXPECT_GT(events_of(lone, Kind::SnapshotLoaded)[0]->frame, partitioned_at);
    EXPECT_NE(events_of(lone, Kind::SnapshotLoaded)[0]->detail.find(": 2 agree, 0 differ, 2 needed of the view's 3 running processes"), std::string::npos)
        << events_of(lone, Kind::SnapshotLoaded)[0]->detail;
    expect_equal_at(cluster, 1200);
    int compared = 0;
    expect_no_disagreement(lone, *cluster.clients[0], compared);
    EXPECT_GE(compared, 150 + 600);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
}

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

// Issue 21: a process playing two slots (slot_hosts: process 2 hosts slot 3) cut off from the
// other two for 10 s. The two are a majority of the three processes: they drop it (and its
// guest) and play on. Healed, it is kicked; a joiner cannot host guest slots yet, so it cannot
// rejoin, and its failure must say so (before, it said only that it was dropped, like a
// process that could rejoin and did not).
TEST(Lifecycle, HostOfTwoSlotsDroppedByAPartitionSaysWhyItCannotRejoin) {
    const auto scene = make_scene(4, 10);
    SessionConfig cfg = real_config(4, 8);
    cfg.slot_hosts = {0, 1, 2, 2};
    Cluster cluster(scene, cfg, {15000, 3000}, 57);
    cluster.run_frames(200);
    bool cut = true;
    split(cluster, {2}, cut);
    cluster.run([](const Cluster&) { return false; }, 10'000'000);
    cut = false;
    rejoin_when_dropped(cluster);  // rejoins whoever can: not the couch
    cluster.run_frames(900, 60'000'000);
    cluster.settle(900);
    const Client& couch = *cluster.clients[2];
    ASSERT_EQ(couch.session->phase(), SessionPhase::Failed);
    EXPECT_EQ(events_of(couch, Kind::Kicked).size(), 1u);
    EXPECT_FALSE(couch.session->can_rejoin());
    EXPECT_NE(couch.session->failure().find("cannot rejoin"), std::string::npos) << couch.session->failure();
    EXPECT_NE(couch.session->failure().find("several slots"), std::string::npos) << couch.session->failure();
    for (PlayerId p : {0u, 1u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << c.session->failure();
        EXPECT_EQ(c.session->slot_state(2), SlotState::Disconnected);
        EXPECT_EQ(c.session->slot_state(3), SlotState::Disconnected);
    }
    expect_equal_at(cluster, 900);
}

TEST(Lifecycle, SplitTwoOneTheOneDropsNobodyThenRejoinsBySnapshot) { split_two_one(8, 43, 0, 200); }
// The same over seeds, lockstep too, and with the one's clock 2 % slow or fast: cut off while
// a few frames behind the pair, it held the pair's inputs of frames the pair then played with
// its neutral input, and confirmed them (a frame is now confirmed only once a majority holds our
// inputs for it).
TEST(Lifecycle, SplitTwoOneTheOneNeverConfirmsOtherwiseEvenWhenBehind) {
    for (std::uint64_t seed = 1; seed <= 6; ++seed)
        for (int window : {8, 0})
            for (std::int64_t drift : {0, -20000, 20000}) {
                SCOPED_TRACE("seed " + std::to_string(seed) + " window " + std::to_string(window) + " drift " +
                             std::to_string(drift));
                split_two_one(window, seed, drift, 200 + static_cast<std::uint32_t>(seed * 7));
            }
}

// Eight players split 5/3 for 10 s: the five drop the three and play on; the three drop nobody
// and stall. Healed, each of the three is kicked, starts again as a joiner of its slot and
// rejoins by a snapshot a majority of the five vouches for, all three at once; every client
// ends on one checksum, nobody in error (issue 21; three joiners at once used to send each
// other their pre-handoff frames as their own until one ignored another for good).
TEST(Lifecycle, SplitFiveThreeHealedTheThreeRejoinBySnapshot) {
    for (std::uint64_t seed : {51u, 52u, 53u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const auto scene = make_scene(8, 10);
        Cluster cluster(scene, real_config(8, 8), {15000, 3000}, seed);
        cluster.run_frames(200);
        bool cut = true;
        split(cluster, {5, 6, 7}, cut);
        cluster.run([](const Cluster&) { return false; }, 10'000'000);
        for (PlayerId p = 5; p < 8; ++p) EXPECT_TRUE(cluster.clients[p]->session->partitioned()) << "client " << p;
        cut = false;
        rejoin_when_dropped(cluster);
        cluster.run_frames(1600, 60'000'000);
        cluster.settle(1600);
        for (PlayerId p = 0; p < 8; ++p) {
            const Client& c = *cluster.clients[p];
            ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
            EXPECT_GE(c.session->confirmed_frame(), 1600u) << "client " << p;
            EXPECT_EQ(c.session->stats().malformed_packets, 0u) << "client " << p;
            EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << p;
            for (PlayerId s = 0; s < 8; ++s) EXPECT_EQ(c.session->slot_state(s), SlotState::Running) << "client " << p << " slot " << s;
            const bool cut_off = p >= 5;
            EXPECT_EQ(events_of(c, Kind::Kicked).size(), cut_off ? 1u : 0u) << "client " << p;
            EXPECT_EQ(events_of(c, Kind::SnapshotLoaded).size(), cut_off ? 1u : 0u) << "client " << p;
            EXPECT_EQ(c.session->config().role, cut_off ? Role::Joiner : Role::Player) << "client " << p;
        }
        expect_equal_at(cluster, 1600);
    }
}

// Four players split 2/2 for 10 s: neither side is a majority, so nobody is dropped; all four
// say Partitioned, and once healed they all play on and confirm equal checksums.
void split_evenly(int players, const std::set<PlayerId>& side, const SessionConfig& cfg) {
    const auto scene = make_scene(players, 10);
    Cluster cluster(scene, cfg, {15000, 3000}, 47);
    cluster.run_frames(200);
    bool cut = true;
    split(cluster, side, cut);
    cluster.run([](const Cluster&) { return false; }, 10'000'000);
    std::uint32_t stalled_at = 0;
    for (const auto& c : cluster.clients) {
        ASSERT_EQ(c->session->phase(), SessionPhase::Running) << c->session->failure();
        EXPECT_TRUE(c->session->partitioned());
        ASSERT_EQ(events_of(*c, Kind::Partitioned).size(), 1u);
        stalled_at = std::max(stalled_at, c->session->confirmed_frame());
    }
    EXPECT_LT(stalled_at, 230u) << "nobody confirms frames the other side has no inputs for";
    cut = false;
    cluster.run_frames(1200, 60'000'000);
    cluster.settle(1200);
    for (const auto& c : cluster.clients) {
        ASSERT_EQ(c->session->phase(), SessionPhase::Running) << c->session->failure();
        EXPECT_FALSE(c->session->partitioned());
        EXPECT_TRUE(events_of(*c, Kind::Disconnected).empty());
        EXPECT_EQ(events_of(*c, Kind::Partitioned).size(), 1u);
        for (int p = 0; p < players; ++p) EXPECT_EQ(c->session->slot_state(static_cast<PlayerId>(p)), SlotState::Running);
    }
    expect_equal_at(cluster, 1200);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
}

TEST(Lifecycle, SplitTwoTwoDropsNobodyAndHeals) { split_evenly(4, {0, 1}, real_config(4, 8)); }
TEST(Lifecycle, SplitTwoTwoDropsNobodyAndHealsLockstep) { split_evenly(4, {0, 2}, real_config(4, 0)); }

// The two-player rule NoDrop: two players who lose each other drop nobody and wait (the default,
// PlayOnAlone, is BothSidesOfAPartitionPlayOn).
TEST(Lifecycle, TwoPlayersNoDropWaitForEachOther) {
    SessionConfig cfg = real_config(2, 8);
    cfg.two_player_rule = TwoPlayerRule::NoDrop;
    split_evenly(2, {0}, cfg);
}

TEST(Lifecycle, ForgedTimeSyncClaimIsBounded) {
    const auto scene = make_scene(2, 4);
    SessionConfig cfg = real_config(2, 8);
    Cluster cluster(scene, cfg, {10000}, 9);
    cluster.run_frames(120);
    // Peer 1 claims to be 30,000 frames ahead on every message.
    cluster.filter = [&](PlayerId from, PlayerId, const std::vector<std::uint8_t>& b) {
        if (from == 1 && !b.empty() && (b[0] & 0x0F) == 1 && (b[0] & 0x10)) {
            InputMessage m;
            if (decode(b, 3, m) == nullptr) {
                m.sender_frame = static_cast<std::uint16_t>(m.sender_frame + 30000);
                m.advantage = -127;
                auto& bytes = const_cast<std::vector<std::uint8_t>&>(b);
                bytes.clear();
                encode(m, 3, bytes);
            }
        }
        return true;
    };
    int longest_wait = 0;
    cluster.before_tick = [&](PlayerId id, Client& c) {
        if (id == 0) longest_wait = std::max(longest_wait, c.skip_ticks);
    };
    cluster.run_frames(600, 60'000'000);
    EXPECT_LE(longest_wait, cfg.input_delay + cfg.prediction_window + 2);
}

// Issue 21, "the wire": a steady match sends its slot table only when it changes, plus a slow
// refresh. Four players, 20 s, no membership change: every peer sends each other at most
// seconds / 2 s (the refresh) + a few tables. It rode every 8th message (150 here) before.
bool carries_table(const std::vector<std::uint8_t>& b) {
    return !b.empty() && (b[0] & 0x0F) == static_cast<std::uint8_t>(MessageKind::Input) && (b[0] & kFlagExtension) != 0;
}

void steady_tables(std::uint32_t loss_ppm) {
    constexpr int kPlayers = 4;
    constexpr std::uint32_t kFrames = 1200;
    const auto scene = make_scene(kPlayers, 10);
    NetParams net{15000, 3000};
    net.loss_ppm = loss_ppm;
    Cluster cluster(scene, real_config(kPlayers, 8), net, 53);
    cluster.run_frames(60);  // past the handshake
    std::map<std::pair<PlayerId, PlayerId>, int> tables;
    int input_messages = 0;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        if (!b.empty() && (b[0] & 0x0F) == static_cast<std::uint8_t>(MessageKind::Input)) ++input_messages;
        if (carries_table(b)) ++tables[{from, to}];
        return true;
    };
    const std::uint64_t start = cluster.now();
    cluster.run_frames(60 + kFrames, 120'000'000);
    const std::uint64_t seconds = (cluster.now() - start) / 1'000'000 + 1;
    EXPECT_GT(input_messages, 1000 * kPlayers * (kPlayers - 1)) << "the match ran";
    int most = 0;
    for (const auto& [link, n] : tables) most = std::max(most, n);
    std::printf("loss %u ppm: at most %d slot tables on one link in %llu s (%zu links carried any)\n", loss_ppm, most,
                static_cast<unsigned long long>(seconds), tables.size());
    EXPECT_LE(most, static_cast<int>(seconds / 2) + 4) << "tables on the busiest link in " << seconds << " s";
    for (const auto& c : cluster.clients) {
        EXPECT_TRUE(events_of(*c, Kind::Disconnected).empty());
        EXPECT_EQ(c->session->stats().desyncs, 0u);
    }
    cluster.settle(60 + kFrames);
    expect_equal_at(cluster, 60 + kFrames);
}

TEST(Lifecycle, SteadyMatchSendsItsSlotTableOnlyWhenItChanges) { steady_tables(0); }
TEST(Lifecycle, SteadyMatchSendsItsSlotTableOnlyWhenItChangesUnderLoss) { steady_tables(50000); }

// A change of the table must still reach every peer when its datagrams are lost. Slots 0 and 3
// cannot hear each other for 6 s (the others hear both): each votes the other gone, one vote of
// four, so nobody is dropped. Healed, each withdraws its vote, and every datagram carrying a
// slot table from either to the two others is lost for lost_us: still, within within_us, no
// peer holds a "gone" vote from them any more (left there, it would help a later single vote
// to a majority).
void withdrawn_vote_reaches_everyone(std::uint64_t lost_us, std::uint64_t within_us) {
    constexpr int kPlayers = 4;
    const auto scene = make_scene(kPlayers, 10);
    Cluster cluster(scene, real_config(kPlayers, 8), {15000, 3000}, 59);
    cluster.run_frames(120);
    bool cut = true;
    std::uint64_t healed_at = 0;
    int lost = 0;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b) {
        const bool across = (from == 0 && to == 3) || (from == 3 && to == 0);
        if (cut) return !across;
        if ((from == 0 || from == 3) && (to == 1 || to == 2) && carries_table(b) && cluster.now() < healed_at + lost_us) {
            ++lost;
            return false;
        }
        return true;
    };
    cluster.run([](const Cluster&) { return false; }, 6'000'000);
    const auto gone_votes_held = [&] {
        int held = 0;
        for (PlayerId p = 0; p < kPlayers; ++p)
            for (const auto& [voter, slot] : {std::pair<PlayerId, PlayerId>{0, 3}, {3, 0}})
                if (p != voter && cluster.clients[p]->session->impl().membership().vote_of(voter, slot) == Vote::Gone) ++held;
        return held;
    };
    // The setup: both votes are out, at the two peers that hear both voters (and at the voters).
    ASSERT_EQ(gone_votes_held(), 4);
    cut = false;
    healed_at = cluster.now();
    cluster.run([&](const Cluster&) { return gone_votes_held() == 0; }, within_us);
    EXPECT_EQ(gone_votes_held(), 0) << "a withdrawn vote is still held " << (cluster.now() - healed_at) / 1000
                                    << " ms after the heal";
    EXPECT_GT(lost, 0) << "the test lost no table";
    std::printf("%d tables lost over %llu ms: every withdrawn vote arrived %llu ms after the heal\n", lost,
                static_cast<unsigned long long>(lost_us / 1000), static_cast<unsigned long long>((cluster.now() - healed_at) / 1000));
    cluster.run_frames(cluster.clients[0]->session->frame() + 300, 60'000'000);
    for (const auto& c : cluster.clients) {
        ASSERT_EQ(c->session->phase(), SessionPhase::Running) << c->session->failure();
        EXPECT_TRUE(events_of(*c, Kind::Disconnected).empty());
        for (PlayerId p = 0; p < kPlayers; ++p) EXPECT_EQ(c->session->slot_state(p), SlotState::Running);
    }
    const std::uint32_t f = cluster.clients[0]->session->frame();
    cluster.settle(f);
    expect_equal_at(cluster, f);
}

// The first copies lost: a later copy of the change arrives within a few messages.
TEST(Lifecycle, LostSlotTableCopyIsRepairedByTheNext) { withdrawn_vote_reaches_everyone(50'000, 400'000); }
// Every copy of the change lost (they span about a second): the refresh, 2 s after the last
// copy, repairs it.
TEST(Lifecycle, LostSlotTableChangeIsRepairedByTheRefresh) { withdrawn_vote_reaches_everyone(1'500'000, 3'500'000); }

// Counts still go where relays are wanted: slot 0's datagrams to slot 3 are lost for 3 s (not
// long enough for a vote). Lagging on 0's stream, 3 sends its counts now and then, and the two
// others relay 0's inputs to it, so 3 keeps confirming frames through the cut.
void relays_through_a_cut(int window) {
    constexpr int kPlayers = 4;
    const auto scene = make_scene(kPlayers, 10);
    Cluster cluster(scene, real_config(kPlayers, window), {15000, 3000}, 61);
    cluster.run_frames(120);
    bool cut = true;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) { return !cut || !(from == 0 && to == 3); };
    const std::uint32_t before = cluster.clients[3]->session->confirmed_frame();
    cluster.run([](const Cluster&) { return false; }, 3'000'000);
    const std::uint32_t during = cluster.clients[3]->session->confirmed_frame() - before;
    std::printf("window %d: slot 3 confirmed %u frames in the 3 s its link from slot 0 was cut\n", window, during);
    EXPECT_GT(during, 100u) << "relays carried 0's stream to 3 (without, it stalls for the whole cut)";
    cut = false;
    cluster.run_frames(cluster.clients[0]->session->frame() + 120, 60'000'000);
    for (const auto& c : cluster.clients) {
        ASSERT_EQ(c->session->phase(), SessionPhase::Running) << c->session->failure();
        EXPECT_TRUE(events_of(*c, Kind::Disconnected).empty());
    }
    const std::uint32_t f = cluster.clients[0]->session->frame();
    cluster.settle(f);
    expect_equal_at(cluster, f);
}

TEST(Lifecycle, APeerStuckOnAGapGetsRelaysInASteadyMatch) { relays_through_a_cut(8); }

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

// Issue 21, what was seen: "a spectator in a kill + rejoin run (3 players, 5 % loss) timed out
// once". lockroll live's kill + rejoin case in virtual time, at 5 % loss with 30 ms of jitter:
// a spectator comes at frame 150, slot 2 is killed at 200 and a new process rejoins it at 400.
// The spectator must follow throughout -- never failed, never dropped by the players, one
// snapshot only -- and end on the players' checksum. Over five seeds. It passes on the tree
// before issue 21 as well (1f05175: 40 seeds, rollback and lockstep), so it guards and did not
// catch: the timeout seen over real processes is not reproduced in virtual time.
void spectator_through_kill_and_rejoin(std::uint64_t seed) {
    const auto scene = make_scene(3, 10);
    SessionConfig cfg = real_config(3, 8);
    cfg.max_spectators = 1;
    cfg.interrupt_us = 500'000;  // live_test's kill + rejoin case: 1.5 s disconnect timeout
    cfg.disconnect_us = 1'500'000;
    Cluster cluster(scene, cfg, {25000, 30000, 50000}, seed);
    cluster.run_frames(150, 30'000'000);
    Client& spectator = start_newcomer(cluster, scene, cfg, Role::Spectator, 3, 1);
    cluster.run_frames(200, 30'000'000);
    cluster.kill(2);
    cluster.run_frames(400, 30'000'000);
    start_newcomer(cluster, scene, cfg, Role::Joiner, 2, 999);
    constexpr std::uint32_t kLast = 1200;
    cluster.run_frames(kLast, 60'000'000);
    cluster.settle(kLast);
    for (PlayerId p : {0u, 1u, 2u}) {
        const Client& c = *cluster.clients[p];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_EQ(c.session->slot_state(2), SlotState::Running) << "client " << p << ": slot 2 did not rejoin";
    }
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
    EXPECT_TRUE(events_of(spectator, Kind::Failed).empty());
    EXPECT_TRUE(events_of(spectator, Kind::Kicked).empty()) << events_of(spectator, Kind::Kicked)[0]->detail;
    EXPECT_EQ(events_of(spectator, Kind::SnapshotLoaded).size(), 1u);
    EXPECT_GE(spectator.session->confirmed_frame(), kLast);
    expect_equal_at(cluster, kLast);
    const auto it = spectator.confirmed.find(kLast);
    ASSERT_NE(it, spectator.confirmed.end());
    EXPECT_EQ(it->second, cluster.clients[0]->confirmed.at(kLast));
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
}

TEST(Lifecycle, SpectatorFollowsAKillAndRejoinAtFivePercentLoss) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        spectator_through_kill_and_rejoin(seed);
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
