// The session lifecycle in virtual time, part 5 of 6: partitions (2/1, 5/3, 2/2, a host of two
// slots), forged slot tables, the slot table on the wire, relays through a cut.

#include "tests/rollback/lifecycle_support.h"

namespace lockroll::rollback {
namespace {

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

// For every frame both clients confirmed, the same checksum.
void expect_no_disagreement(const Client& a, const Client& b, int& compared) {
    for (const auto& [frame, checksum] : a.confirmed) {
        const auto it = b.confirmed.find(frame);
        if (it == b.confirmed.end()) continue;
        ++compared;
        ASSERT_EQ(it->second, checksum) << "confirmed frame " << frame;
    }
}

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

// Issue 21, "a process that cannot reach a majority of the view stops confirming frames and
// reports Partitioned": a joiner too. A new process of slot 2 in a match of three hears only
// the owner (slot 0), only slot 1, or nobody. Before, it reported nothing of the kind: it sat in
// its sync phase (rejecting each offer it could not vet, at best) until its runner's connect
// timeout, 30 s and more, ended it `connect_timeout`. Now, within disconnect_us (+ slack) of
// starting it reports `partitioned` (reason no_majority, its confirmed frame), never loads a
// snapshot the majority did not vet while cut, and once healed joins by a vetted snapshot and
// confirms the majority's checksums.
void joiner_cut_off(std::set<PlayerId> unreachable) {
    const auto scene = make_scene(3, 20);
    const SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {10000, 2000}, 17);
    bool cut = true;
    Client& joiner = start_cut_off_joiner(cluster, scene, cfg, unreachable, cut);
    const std::uint64_t started = cluster.now();
    // The silence a player waits before its vote, and a little more for the round trips.
    const std::uint64_t bound = cfg.disconnect_us + 2 * cfg.interrupt_us;
    cluster.run([&](const Cluster&) { return !events_of(joiner, Kind::Partitioned).empty(); }, bound);
    ASSERT_FALSE(events_of(joiner, Kind::Partitioned).empty())
        << "a joiner cut off from the majority says so within " << bound / 1000 << " ms";
    const SessionEvent told = *events_of(joiner, Kind::Partitioned)[0];  // a copy: events grows
    EXPECT_LE(told.at_us - started, bound);
    EXPECT_EQ(told.reason, SessionEvent::Reason::NoMajority);
    EXPECT_EQ(told.peer, 2u);
    EXPECT_EQ(told.frame, joiner.session->confirmed_frame()) << "its confirmed frame";
    EXPECT_NE(told.detail.find("no majority"), std::string::npos) << told.detail;
    EXPECT_TRUE(joiner.session->partitioned());
    // Cut for three timeouts: it loads nothing, never runs, and the two others play on.
    const std::uint32_t before = cluster.clients[0]->session->frame();
    cluster.run([](const Cluster&) { return false; }, 3 * cfg.disconnect_us);
    EXPECT_TRUE(events_of(joiner, Kind::SnapshotLoaded).empty()) << events_of(joiner, Kind::SnapshotLoaded)[0]->detail;
    EXPECT_TRUE(events_of(joiner, Kind::Synchronized).empty());
    EXPECT_NE(joiner.session->phase(), SessionPhase::Running);
    for (PlayerId p : {0u, 1u}) {
        EXPECT_GT(cluster.clients[p]->session->frame(), before + 60 * 3 * cfg.disconnect_us / 1'000'000 / 3) << "client " << p;
        EXPECT_TRUE(events_of(*cluster.clients[p], Kind::Partitioned).empty()) << "client " << p << " hears a majority";
    }
    // Healed: it joins by a snapshot the majority vetted, and confirms their checksums.
    cut = false;
    const std::uint32_t end = cluster.clients[0]->session->frame() + 600;
    cluster.run_frames(end, 120'000'000);
    cluster.settle(end);
    ASSERT_EQ(joiner.session->phase(), SessionPhase::Running) << joiner.session->failure();
    EXPECT_FALSE(joiner.session->partitioned());
    const auto loaded = events_of(joiner, Kind::SnapshotLoaded);
    ASSERT_EQ(loaded.size(), 1u);
    EXPECT_GT(loaded[0]->at_us, events_of(joiner, Kind::Partitioned).back()->at_us);
    EXPECT_NE(loaded[0]->detail.find(": 2 agree, 0 differ, 2 needed"), std::string::npos) << loaded[0]->detail;
    for (PlayerId p : {0u, 1u}) EXPECT_EQ(cluster.clients[p]->session->slot_state(2), SlotState::Running);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
    expect_equal_at(cluster, end);
}

TEST(Lifecycle, AJoinerThatHearsOnlyTheOwnerReportsPartitioned) { joiner_cut_off({1}); }
TEST(Lifecycle, AJoinerThatHearsOnlyANonOwnerReportsPartitioned) { joiner_cut_off({0}); }
TEST(Lifecycle, AJoinerThatHearsNobodyReportsPartitioned) { joiner_cut_off({0, 1}); }

// Issue 21, the same for a process restarted with its usual settings (role Player, no `join`):
// slot 2 of three dies at frame 200 and a new process of it says hello as a player 0.3 s later,
// while every datagram between it and the slots in `unreachable` is lost. A peer it reaches
// answers its hello `retry` (the restart claim has not stood yet) or, once it dropped the slot,
// `disconnected`: only another incarnation of a slot in a running match is told that, so the
// process knows it had been in the match, and from then on it is judged as a joiner is
// (rollback/joiner_reach.h). One refusal of two is no majority, so it is never kicked; before,
// it sat in its sync phase saying nothing until its runner's connect timeout ended it
// `connect_timeout`. Now it reports `partitioned` (no_majority) within disconnect_us (+ slack)
// of starting, and once healed it is kicked, rejoins as a joiner and confirms the majority's
// checksums. With `unreachable` all of them it hears nobody for `deaf_us` first: then it cannot
// tell a restart from a first start that nobody answers (connect_timeout is what it knows), and
// says nothing, until the first refusal arrives.
void restarted_player_cut_off(std::set<PlayerId> unreachable, std::uint64_t deaf_us = 0) {
    const auto scene = make_scene(3, 20);
    const SessionConfig cfg = real_config(3, 8);
    Cluster cluster(scene, cfg, {10000, 2000}, 23);
    rejoin_when_dropped(cluster);
    cluster.run_frames(200);
    cluster.kill(2);
    // Cut from the kill on, so that nothing the cut-off slots sent the old process is still on
    // its way when the new one starts (between real processes the new connection never sees it).
    bool deaf = deaf_us > 0, cut = true;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        const bool crosses = (from == 2 && (deaf || unreachable.count(to))) || (to == 2 && (deaf || unreachable.count(from)));
        return !(cut && crosses);
    };
    cluster.run([](const Cluster&) { return false; }, 300'000);
    SessionConfig again = cfg;
    again.local_player = 2;  // role Player, as it first started
    Client& restarted = cluster.start(2, scene, again, 999);
    const std::uint64_t started = cluster.now();
    if (deaf) {
        cluster.run([](const Cluster&) { return false; }, deaf_us);
        EXPECT_TRUE(events_of(restarted, Kind::Partitioned).empty())
            << "a process that heard nobody cannot know it restarted: " << events_of(restarted, Kind::Partitioned)[0]->detail;
        EXPECT_FALSE(restarted.session->partitioned());
        deaf = false;  // now it hears the slots not in `unreachable`
    }
    const std::uint64_t bound = cfg.disconnect_us + 2 * cfg.interrupt_us;
    const std::uint64_t hearing = cluster.now();
    cluster.run([&](const Cluster&) { return !events_of(restarted, Kind::Partitioned).empty(); },
                deaf_us > 0 ? 1'000'000 : bound);
    ASSERT_FALSE(events_of(restarted, Kind::Partitioned).empty())
        << "a restarted player cut off from the majority says so (phase " << static_cast<int>(restarted.session->phase()) << ")";
    const SessionEvent told = *events_of(restarted, Kind::Partitioned)[0];
    if (deaf_us > 0) EXPECT_LE(told.at_us - hearing, 1'000'000u) << "once refused, at once (its silence already outlasted the timeout)";
    else EXPECT_LE(told.at_us - started, bound);
    EXPECT_EQ(told.reason, SessionEvent::Reason::NoMajority);
    EXPECT_EQ(told.peer, 2u);
    EXPECT_NE(told.detail.find("no majority"), std::string::npos) << told.detail;
    EXPECT_TRUE(restarted.session->partitioned());
    EXPECT_TRUE(events_of(restarted, Kind::Synchronized).empty()) << "it never ran frame 0 of a running match";
    EXPECT_TRUE(events_of(restarted, Kind::Kicked).empty()) << "one refusal of two is no majority";
    // The two others dropped it and play on.
    cluster.run([](const Cluster&) { return false; }, cfg.disconnect_us);
    for (PlayerId p : {0u, 1u}) {
        EXPECT_EQ(cluster.clients[p]->session->slot_state(2), SlotState::Disconnected) << "client " << p;
        EXPECT_TRUE(events_of(*cluster.clients[p], Kind::Partitioned).empty()) << "client " << p << " hears a majority";
    }
    // Healed: refused by both, it is kicked, rejoins as a joiner and confirms their checksums.
    cut = false;
    const std::uint32_t end = cluster.clients[0]->session->frame() + 600;
    cluster.run_frames(end, 120'000'000);
    cluster.settle(end);
    Client& back = *cluster.clients[2];
    ASSERT_EQ(back.session->phase(), SessionPhase::Running) << back.session->failure();
    EXPECT_FALSE(back.session->partitioned());
    EXPECT_EQ(events_of(back, Kind::SnapshotLoaded).size(), 1u);
    for (const auto& c : cluster.clients) EXPECT_EQ(c->session->stats().desyncs, 0u);
    expect_equal_at(cluster, end);
}

TEST(Lifecycle, ARestartedPlayerThatHearsOnlyOnePeerReportsPartitioned) {
    restarted_player_cut_off({1});
    restarted_player_cut_off({0});
}
TEST(Lifecycle, ARestartedPlayerThatHearsNobodySaysNothingUntilAPeerRefusesIt) { restarted_player_cut_off({1}, 8'000'000); }


// Issue 21, "membership that cannot split" (lockroll live, 3 players, 5 % loss): the machine
// stalled and every process stopped for 3.2 s at once, longer than disconnect_us. Here three
// players at 5 % loss (rollback, input delay 0) play to frame 300, then each client in `stalls`
// stops (no tick, no poll; datagrams already on the way arrive meanwhile) for its own time, and
// they all resume. On resuming, each finds every other silent past the timeout and votes it gone
// at once, and only then hears it again. Whatever follows, no two clients may confirm a frame
// with different checksums, nobody may desync, and a slot is either dropped by nobody or by
// every process that plays on, from the same frame (the dropped one rejoins as a joiner, as a
// runner does); the match goes on to frame 900 at everyone.
void global_freeze(std::uint64_t seed, std::map<PlayerId, std::uint64_t> stalls, int players = 3) {
    const auto scene = make_scene(players, 10);
    SessionConfig cfg = real_config(players, 8);
    cfg.input_delay = 0;
    cfg.interrupt_us = 500'000;  // lockroll live's settings: --disconnect-timeout 1.5
    cfg.disconnect_us = 1'500'000;
    NetParams net{20000, 8000, 50000};
    Cluster cluster(scene, cfg, net, seed);
    rejoin_when_dropped(cluster);
    cluster.run_frames(300);
    const std::uint64_t frozen_at = cluster.now();
    for (const auto& [p, us] : stalls) cluster.clients[p]->frozen = true;
    for (;;) {
        bool any = false;
        for (const auto& [p, us] : stalls) {
            Client& c = *cluster.clients[p];
            if (c.frozen && cluster.now() >= frozen_at + us) c.frozen = false;
            any = any || c.frozen;
        }
        if (!any) break;
        cluster.step_event();
    }
    cluster.run_frames(900, 60'000'000);
    cluster.settle(900, 20'000'000);
    std::string story;
    for (std::size_t i = 0; i < cluster.clients.size(); ++i)
        for (const SessionEvent& e : cluster.clients[i]->events)
            if (e.at_us >= frozen_at && e.kind != Kind::Interrupted)
                story += "\n  client " + std::to_string(i) + " @" + std::to_string((e.at_us - frozen_at) / 1000) + "ms " +
                         event_name(e.kind) + " peer " + std::to_string(e.peer) + " frame " + std::to_string(e.frame) + " " +
                         e.detail;
    SCOPED_TRACE(story);
    std::map<PlayerId, std::set<std::uint32_t>> neutral_from;  // dropped slot -> frames its neutral input starts
    std::set<PlayerId> dropped;
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        const Client& c = *cluster.clients[i];
        ASSERT_EQ(c.session->phase(), SessionPhase::Running) << "client " << i << ": " << c.session->failure();
        EXPECT_GE(c.session->confirmed_frame(), 900u) << "client " << i;
        EXPECT_FALSE(c.session->partitioned()) << "client " << i;
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << i;
        for (const SessionEvent* e : events_of(c, Kind::Disconnected)) dropped.insert(e->peer);
        for (const SessionEvent* e : events_of(c, Kind::NeutralFrom)) neutral_from[e->peer].insert(e->frame);
    }
    if (players == 3) {
        EXPECT_LE(dropped.size(), 1u) << "more than one slot dropped";
        for (PlayerId d : dropped) {
            // Every other client dropped it (it was kicked and rejoined), from one frame.
            for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
                if (i == d) continue;
                EXPECT_EQ(events_of(*cluster.clients[i], Kind::Disconnected).size(), 1u) << "client " << i << " about slot " << d;
            }
            EXPECT_EQ(neutral_from[d].size(), 1u) << "slot " << d << "'s neutral input starts at different frames";
        }
    } else {
        // Several may go, one at a time: every process never dropped itself saw the same drops,
        // with the same neutral frames.
        std::map<std::size_t, std::map<PlayerId, std::set<std::uint32_t>>> seen;
        for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
            if (dropped.count(static_cast<PlayerId>(i))) continue;
            auto& mine = seen[i];
            for (const SessionEvent* e : events_of(*cluster.clients[i], Kind::NeutralFrom)) mine[e->peer].insert(e->frame);
        }
        for (const auto& [i, drops] : seen) EXPECT_EQ(drops, seen.begin()->second) << "client " << i << " against " << seen.begin()->first;
    }
    for (std::size_t a = 0; a < cluster.clients.size(); ++a)
        for (std::size_t b = a + 1; b < cluster.clients.size(); ++b) {
            int compared = 0;
            expect_no_disagreement(*cluster.clients[a], *cluster.clients[b], compared);
        }
    expect_equal_at(cluster, 900);
}

// All three failed on main before the agreement (59c94a2, 5a2c8cc), in every seed of 1..8: a
// peer's "gone" vote, cast while its caster heard nobody, was counted by each receiver towards
// whichever drop it wanted, and a drop was applied by whoever first saw a majority. Each process
// resuming from the stall votes every other gone (silent 3.2 s > disconnect_us) and withdraws a
// vote only when it hears that peer again; its table still carrying the other votes lent each
// receiver the second vote of a different drop (global freeze, seed 1: 0 dropped 2 on 1's stale
// "2 gone" while 1 and 2 dropped 0 on each other's; confirmed frame 301 differed). Counting a
// voter's "gone" only while it hears a majority fixed the global freeze and not the two others.
// Now votes only propose, and a drop is applied once a majority accepted that very slot
// (rollback/drop_agreement.h): a stall may still cost a player (kicked, it rejoins), never a split.
TEST(Lifecycle, GlobalFreezeLongerThanTheTimeoutSplitsNobody) {
    for (std::uint64_t seed = 1; seed <= 32; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        global_freeze(seed, {{0, 3'200'000}, {1, 3'200'000}, {2, 3'200'000}});
    }
}
TEST(Lifecycle, FreezeOfTwoOfThreeSplitsNobody) {
    for (std::uint64_t seed = 1; seed <= 32; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        global_freeze(seed, {{0, 3'200'000}, {1, 3'200'000}});
    }
}
// Five players, four frozen for different times around the timeout (one voter never stalls):
// votes of every age cross, and still one view. Seed 146 desynced: slot 1's rejoin lapsed while
// its process sent, and the owner took the peers' votes for the drop applied, starting the
// neutral input below inputs they then confirmed (rollback/authored_streams.h). Seeds 1..200
// pass (run by hand: 7 s).
TEST(Lifecycle, FiveFrozenUnevenlySplitNobody) {
    for (std::uint64_t seed = 1; seed <= 33; ++seed) {
        const std::uint64_t s = seed == 33 ? 146 : seed;
        SCOPED_TRACE("seed " + std::to_string(s));
        global_freeze(s, {{0, 2'000'000}, {1, 3'200'000}, {2, 2'600'000}, {3, 1'700'000}}, 5);
    }
}
TEST(Lifecycle, UnevenFreezeSplitsNobody) {
    for (std::uint64_t seed = 1; seed <= 32; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        global_freeze(seed, {{0, 2'000'000}, {1, 3'200'000}, {2, 3'200'000}});
    }
}

}  // namespace
}  // namespace lockroll::rollback
