// Issue 21, "relayed inputs overwrite a running player": while a slot is in the view only its
// own process authors its inputs. In virtual time, over the in-test network: three players, the
// link from 1 to 0 cut for a second, so 2 relays 1's stream to 0 -- honestly, or altered (an
// equivocating relay). (Lockstep does not relay through a one-way cut: the owner stalls on the
// cut peer's stream before any relay lags far enough.) The owner's own copy wins, the relay is counted and ignored, and nobody
// is dropped or blamed but the relay (docs/sessions.md, "Relayed inputs").
#include <gtest/gtest.h>

#include <cstdio>

#include "rollback/session.h"
#include "tests/rollback/equivocating_relay.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::Client;
using testing::Cluster;
using testing::make_scene;
using Kind = SessionEvent::Kind;

SessionConfig relay_config(int window) {
    SessionConfig c = testing::real_config(3, window);
    // Confirmation may wait on a relayed input for prediction_window + evidence_frames / 2
    // frames (about 2.3 s here): the cut below is shorter, so every owner's copy comes in time.
    c.evidence_frames = 256;
    return c;
}

std::size_t count_events(const Client& c, Kind k) {
    std::size_t n = 0;
    for (const SessionEvent& e : c.events) n += e.kind == k ? 1 : 0;
    return n;
}

struct Outcome {
    std::uint64_t disagreements = 0;   // client 0's count against relay 2
    std::uint64_t altered = 0;         // relayed inputs 2 altered
    std::uint32_t frames_in_cut = 0;   // frames 0 advanced while cut from 1
};

Outcome run_cut(int window, bool attack, std::uint64_t seed, std::uint32_t loss_ppm = 0) {
    const auto scene = make_scene(3, 10);
    Cluster cluster(scene, relay_config(window), {15000, 3000, loss_ppm}, seed);
    Outcome out;
    if (attack) testing::equivocate(cluster, 2, 0, 1, out.altered);  // 2 alters 1's inputs it relays to 0
    cluster.run_frames(120);
    bool cut = true;
    cluster.filter = [&cut](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return !cut || !(from == 1 && to == 0);
    };
    const std::uint32_t before = cluster.clients[0]->session->frame();
    cluster.run([](const Cluster&) { return false; }, 1'000'000);
    out.frames_in_cut = cluster.clients[0]->session->frame() - before;
    cut = false;
    cluster.run_frames(cluster.clients[0]->session->frame() + 240, 60'000'000);
    const std::uint32_t f = cluster.clients[0]->session->frame() - 60;
    cluster.settle(f);
    std::printf("window %d, loss %u ppm, %s relay: 0 advanced %u frames in the 1 s cut from 1; 2 altered %llu relayed inputs\n",
                window, loss_ppm, attack ? "equivocating" : "honest", out.frames_in_cut,
                static_cast<unsigned long long>(out.altered));
    std::optional<std::uint64_t> final_checksum;
    for (PlayerId p = 0; p < 3; ++p) {
        const Client& c = *cluster.clients[p];
        EXPECT_EQ(c.session->phase(), SessionPhase::Running) << "client " << p << ": " << c.session->failure();
        EXPECT_EQ(count_events(c, Kind::Disconnected), 0u) << "client " << p;
        EXPECT_EQ(count_events(c, Kind::Kicked), 0u) << "client " << p;
        EXPECT_EQ(c.session->stats().desyncs, 0u) << "client " << p << ": the owner's inputs were used";
        for (PlayerId q = 0; q < 2; ++q) {
            EXPECT_EQ(c.session->stats().peers[q].malformed_packets, 0u) << "client " << p << " blames " << q;
        }
        const auto it = c.confirmed.find(f);
        EXPECT_NE(it, c.confirmed.end()) << "client " << p << " never confirmed frame " << f;
        if (it == c.confirmed.end()) continue;
        if (!final_checksum) final_checksum = it->second;
        EXPECT_EQ(it->second, *final_checksum) << "client " << p << " differs at frame " << f;
    }
    out.disagreements = cluster.clients[0]->session->stats().peers[2].relay_disagreements;
    EXPECT_EQ(cluster.clients[0]->session->stats().peers[1].relay_disagreements, 0u);
    return out;
}

TEST(RelayAuthority, HonestRelayCarriesTheStreamThroughACut) {
    const Outcome o = run_cut(8, false, 61);
    EXPECT_GT(o.frames_in_cut, 20u) << "2's relays let 0 play on (without, it stalls after the window)";
    EXPECT_EQ(o.disagreements, 0u);
}

TEST(RelayAuthority, EquivocatingRelayIsCountedAndTheOwnerWins) {
    const Outcome o = run_cut(8, true, 61);
    ASSERT_GT(o.altered, 0u) << "the attack must have been tried";
    EXPECT_GT(o.disagreements, 0u) << "0 counted 2's altered inputs";
}

TEST(RelayAuthority, EquivocatingRelayIsCountedAndTheOwnerWinsUnderLoss) {
    const Outcome o = run_cut(8, true, 62, 50'000);
    ASSERT_GT(o.altered, 0u) << "the attack must have been tried";
    EXPECT_GT(o.disagreements, 0u);
}

}  // namespace
}  // namespace lockroll::rollback
