// Long runs under the harsh network goal (label "soak": excluded from the default test
// run; `ctest -L soak` runs them). They check the session core alone, over the in-test network.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <string>

#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Cluster;
using testing::make_scene;
using testing::NetParams;

void expect_all_agree(Cluster& cluster, std::uint32_t frames) {
    const Replay& first = cluster.clients[0]->recorder.replay();
    for (const auto& c : cluster.clients) {
        const Replay& r = c->recorder.replay();
        ASSERT_GE(r.frames(), frames);
        for (std::uint32_t f = 0; f < frames; ++f) ASSERT_EQ(r.checksums[f], first.checksums[f]) << "frame " << f + 1;
        EXPECT_TRUE(c->desyncs.empty());
        for (const auto& p : c->session->stats().peers) EXPECT_EQ(p.checksum_mismatches, 0u);
    }
}

// The harsh network: 150 +- 50 ms one way, 20 % loss, 5 % duplication, 10 % reordering.
NetParams harsh_network() {
    NetParams net;
    net.latency_us = 100000;
    net.jitter_us = 100000;
    net.loss_ppm = 200000;
    net.duplicate_ppm = 50000;
    net.reorder_ppm = 100000;
    return net;
}

// The harsh network, 8 players, 10 minutes.
TEST(Soak, EightPlayersTenMinutesHarshNetwork) {
    const auto scene = make_scene(8, 50);
    SessionConfig cfg;
    cfg.players = 8;
    cfg.input_delay = 3;
    const NetParams net = harsh_network();
    if (const char* w = std::getenv("SOAK_TS_WINDOW")) cfg.time_sync_window = std::atoi(w);
    if (const char* m = std::getenv("SOAK_TS_MIN")) cfg.time_sync_min_frames = std::atoi(m);
    if (const char* d = std::getenv("SOAK_DELAY")) cfg.input_delay = std::atoi(d);
    Cluster cluster(scene, cfg, net, 2024);
    const std::uint32_t frames = std::getenv("SOAK_FRAMES") ? static_cast<std::uint32_t>(std::atoi(std::getenv("SOAK_FRAMES"))) : 36000;
    cluster.run_frames(frames, 3600'000'000);
    cluster.settle(frames);
    expect_all_agree(cluster, frames);
    WorldSimulation reference(scene, 8);
    const auto mismatch = verify_replay(cluster.clients[3]->recorder.replay(), reference);
    EXPECT_FALSE(mismatch.has_value());
    const auto& st = cluster.clients[0]->session->stats();
    std::printf("8 players, %u frames in %.1f s: ticks %llu, frames %llu, stalls %llu, rollbacks %llu (max depth %u), "
                "time-sync waits %llu, bytes sent %llu/s\n", frames, static_cast<double>(cluster.now()) / 1e6,
                static_cast<unsigned long long>(st.ticks), static_cast<unsigned long long>(st.frames_advanced),
                static_cast<unsigned long long>(st.stall_ticks), static_cast<unsigned long long>(st.rollbacks),
                st.max_rollback_depth, static_cast<unsigned long long>(st.time_sync_waits),
                static_cast<unsigned long long>(st.bytes_sent * 60 / st.ticks));
}

// Payload bytes per second at the paper's conditions (2 players, 57 ms one way, jitter 0..20 ms).
TEST(Soak, PaperConditionsBandwidth) {
    for (std::uint32_t loss : {0u, 200000u}) {
        for (int interval : {1, 2, 4}) {
            const auto scene = make_scene(2, 50);
            SessionConfig cfg;
            cfg.checksum_interval = interval;
            cfg.input_delay = 2;
            NetParams net;
            net.latency_us = 47000;
            net.jitter_us = 20000;
            net.loss_ppm = loss;
            Cluster cluster(scene, cfg, net, 7);
            cluster.run_frames(3600);
            const auto& st = cluster.clients[0]->session->stats();
            const double seconds = static_cast<double>(cluster.now()) / 1e6;
            std::printf("loss %u%% K=%d: sent %.0f B/s, received %.0f B/s, %.1f bytes/packet\n", loss / 10000, interval,
                        static_cast<double>(st.bytes_sent) / seconds, static_cast<double>(st.bytes_received) / seconds,
                        static_cast<double>(st.bytes_sent) / static_cast<double>(st.packets_sent));
            cluster.settle(3500);
            expect_all_agree(cluster, 3500);
        }
    }
}

std::uint64_t rss_kib() {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("VmRSS:", 0) == 0) return std::stoull(line.substr(6));
    return 0;
}

// The harsh network with churn: every 2 minutes of virtual time one player's process
// dies, and a new process rejoins its slot 20 s later by snapshot; a minute after each kill,
// three slots (1..7, rotating) are cut off from the other five for 20 s: the five drop them and
// play on, the three say Partitioned and confirm nothing otherwise, and once healed each is
// told it was dropped and rejoins its slot by snapshot in place (Session::restart_as_joiner, as
// net::PeerRunner does). Every 10 s every running process must have confirmed the same
// checksum and the same inputs of a recent frame (so no confirmed input was lost or changed by
// a drop, a partition or a join), nobody may desync, every process runs at the end, and the
// process's memory must not grow between the 10-minute mark and the end. SOAK_MINUTES sets the
// length (60 by hand; the default tier's churn_soak_short runs 3: one partition, one kill).
TEST(Soak, EightPlayersWithKillsAndRejoins) {
    const int minutes = std::getenv("SOAK_MINUTES") ? std::atoi(std::getenv("SOAK_MINUTES")) : 60;
    const auto scene = make_scene(8, 50);
    SessionConfig cfg;
    cfg.players = 8;
    cfg.input_delay = 3;
    cfg.handshake = true;
    cfg.match_id = 77;
    const NetParams net = harsh_network();
    Cluster cluster(scene, cfg, net, 4242);
    for (auto& c : cluster.clients) {
        c->record_replay = false;
        c->history_limit = 2048;
    }
    const std::uint64_t kill_every_us = 120'000'000;
    const std::uint64_t end_us = static_cast<std::uint64_t>(minutes) * 60'000'000;
    std::uint64_t next_kill = kill_every_us, next_check = 10'000'000, rss_at_10 = 0;
    std::optional<std::pair<PlayerId, std::uint64_t>> pending_rejoin;
    int kills = 0, rejoins = 0, checks = 0, partitions = 0, healed_rejoins = 0;
    std::uint64_t seed = 1;
    // The partition: while `cut_until` is ahead, no datagram crosses between `minority` and the
    // rest. A kicked minority member starts again as a joiner of its slot.
    // SOAK_PARTITIONS=0: kills and rejoins only (the soak as it was before partitions).
    const bool no_partitions = std::getenv("SOAK_PARTITIONS") && std::string(std::getenv("SOAK_PARTITIONS")) == "0";
    std::uint64_t next_cut = kill_every_us / 2, cut_until = 0;
    std::set<PlayerId> minority;
    cluster.filter = [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return cluster.now() >= cut_until || minority.count(from) == minority.count(to);
    };
    cluster.before_tick = [&](PlayerId, testing::Client& c) {
        if (c.session->phase() != SessionPhase::Failed || !c.session->can_rejoin()) return;
        for (SessionEvent e; c.session->next_event(e);) c.events.push_back(e);
        if (c.session->restart_as_joiner()) {
            c.catches_up = true;
            ++healed_rejoins;
        }
    };
    while (cluster.now() < end_us) {
        cluster.run([&](const Cluster& c) { return c.now() >= std::min({next_kill, next_check, next_cut, end_us}) ||
                                                    (pending_rejoin && c.now() >= pending_rejoin->second); },
                    end_us);
        if (cluster.now() >= next_cut) {
            next_cut += kill_every_us;
            // Healed at least 40 s before the end, so the three are back when it comes.
            if (cluster.now() + 60'000'000 <= end_us && !no_partitions) {
                minority.clear();
                for (int k = 0; k < 3; ++k) minority.insert(static_cast<PlayerId>(1 + (partitions + k) % 7));
                cut_until = cluster.now() + 20'000'000;
                ++partitions;
            }
        }
        if (pending_rejoin && cluster.now() >= pending_rejoin->second) {
            SessionConfig again = cfg;
            again.local_player = pending_rejoin->first;
            again.role = Role::Joiner;
            auto& c = cluster.start(pending_rejoin->first, scene, again, 100 + seed++);
            c.record_replay = false;
            c.history_limit = 2048;
            pending_rejoin.reset();
            ++rejoins;
        }
        if (cluster.now() >= next_kill) {
            next_kill += kill_every_us;
            if (!pending_rejoin) {
                const auto victim = static_cast<PlayerId>(1 + kills % 7);  // slot 0 too would test owner change
                cluster.kill(victim);
                pending_rejoin = std::make_pair(victim, cluster.now() + 20'000'000);
                ++kills;
            }
        }
        if (cluster.now() >= next_check) {
            next_check += 10'000'000;
            std::uint32_t common = UINT32_MAX;
            for (std::size_t i = 0; i < cluster.clients.size(); ++i)
                if (cluster.counts(i) && cluster.clients[i]->session->running())
                    common = std::min(common, cluster.clients[i]->session->confirmed_frame());
            if (common == UINT32_MAX || common < 200) continue;
            const std::uint32_t f = common - 100;
            const testing::Client* ref = nullptr;
            for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
                if (!cluster.counts(i) || !cluster.clients[i]->session->running()) continue;
                const auto& c = *cluster.clients[i];
                if (!c.confirmed.count(f)) continue;  // a joiner that started after f
                if (!ref) {
                    ref = &c;
                    continue;
                }
                ASSERT_EQ(c.confirmed.at(f), ref->confirmed.at(f)) << "client " << i << " frame " << f;
                ASSERT_EQ(c.confirmed_inputs.at(f), ref->confirmed_inputs.at(f)) << "client " << i << " frame " << f;
            }
            ++checks;
            if (cluster.now() >= 600'000'000 && rss_at_10 == 0) rss_at_10 = rss_kib();
        }
    }
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        if (!cluster.counts(i)) continue;
        EXPECT_TRUE(cluster.clients[i]->desyncs.empty()) << "client " << i;
        EXPECT_EQ(cluster.clients[i]->session->phase(), SessionPhase::Running) << "client " << i;
        if (std::getenv("SOAK_EVENTS"))
            for (const auto& e : cluster.clients[i]->events)
                if (e.kind != SessionEvent::Kind::Synchronizing && (i < 2 || cluster.clients[i]->session->phase() != SessionPhase::Running))
                    std::printf("%zu %s peer %u frame %u t %.2f %s\n", i, event_name(e.kind), e.peer, e.frame, e.at_us / 1e6, e.detail.c_str());
    }
    const std::uint64_t rss_end = rss_kib();
    std::printf("churn soak: %d min virtual, %d kills, %d rejoins, %d partitions, %d rejoins after a partition, "
                "%d agreement checks, RSS %llu KiB at 10 min, %llu KiB at the end\n",
                minutes, kills, rejoins, partitions, healed_rejoins, checks,
                static_cast<unsigned long long>(rss_at_10), static_cast<unsigned long long>(rss_end));
    EXPECT_GT(kills, 0);
    if (!no_partitions) {
        EXPECT_GT(partitions, 0);
    }
    // Each partition's three were dropped by the five and came back by snapshot.
    EXPECT_EQ(healed_rejoins, 3 * partitions);
    EXPECT_GT(checks, 0);
    if (rss_at_10 != 0) {
        EXPECT_LE(rss_end, rss_at_10 + rss_at_10 / 10 + 8192);
    }
}

}  // namespace
}  // namespace lockroll::rollback
