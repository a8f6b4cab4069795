// DesyncDetector on its own (rollback/desync_detector.h): which confirmed checksums get
// compared and when, one alert per peer, bounded memory, and narrowing a mismatch down to the
// first differing frame, body and field by query/reply. Two detectors over the test scene of
// test_support.h talk to each other directly (no session, no network), so every query and reply
// is visible to the test.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "rollback/desync_detector.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using testing::make_scene;

struct Recorder : SessionObserver {
    void on_desync(const DesyncEvent& e) override { desyncs.push_back(e); }
    void on_desync_report(const DesyncReport& r) override { reports.push_back(r); }
    std::vector<DesyncEvent> desyncs;
    std::vector<DesyncReport> reports;
};

// A distinct, arbitrary checksum per frame (and a second series that differs from it).
std::uint64_t sum(std::uint32_t frame) { return 0x9E3779B97F4A7C15ull * (frame + 1); }
std::uint64_t other(std::uint32_t frame) { return sum(frame) ^ 0x5A5A; }

// One client's side: its game, its snapshot ring and its detector. confirm() steps the game one
// frame, saves it into the ring and tells the detector, as a session does on confirmation.
struct Side {
    Side(PlayerId local, int players = 2, DesyncConfig config = {}, std::size_t ring_slots = 64)
        : sim(make_scene(2, 4), 2),
          ring(ring_slots, sim.state_size()),
          detector(config, players, local, sim, ring, &recorder, stats) {
        save(0);
        detector.add_local(0, checksum(0));
    }
    std::uint64_t confirm() {
        sim.step(std::vector<std::uint8_t>(2 * kWorldInputSize, 0));
        ++frame;
        save(frame);
        detector.add_local(frame, checksum(frame));
        return checksum(frame);
    }
    void save(std::uint32_t f) { ring.set_used(f, sim.save_to(ring.slot_for(f)).size()); }
    std::uint64_t checksum(std::uint32_t f) const { return sim.checksum(*ring.find(f)); }

    WorldSimulation sim;
    SnapshotRing ring;
    Recorder recorder;
    SessionStats stats;
    DesyncDetector detector;
    std::uint32_t frame = 0;
};

// A detector with no saved states: enough for the comparison rules (a mismatch then ends as
// EvidenceMissing, which the tests use as the "one report" marker).
struct Bare {
    explicit Bare(int players = 2, DesyncConfig config = {})
        : sim(make_scene(2, 0), 2), ring(1, sim.state_size()), detector(config, players, 0, sim, ring, &recorder, stats) {}
    void local(std::uint32_t from, std::uint32_t to) {  // frames [from, to] with sum()
        for (std::uint32_t f = from; f <= to; ++f) detector.add_local(f, sum(f));
    }
    WorldSimulation sim;
    SnapshotRing ring;
    Recorder recorder;
    SessionStats stats;
    DesyncDetector detector;
};

// Delivers every query `from` has due now to `to` and its answer back; returns queries sent.
std::size_t exchange(Side& from, PlayerId to_id, const Side& to, std::uint64_t now_us) {
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    from.detector.collect_queries(now_us, out);
    for (const auto& [peer, q] : out) {
        EXPECT_EQ(peer, to_id);
        from.detector.on_reply(peer, to.detector.answer(q));
    }
    return out.size();
}

TEST(DesyncDetector, ConstructionChecksTheHistory) {
    WorldSimulation sim(make_scene(2, 0), 2);
    SnapshotRing ring(4, sim.state_size());
    SessionStats stats;
    DesyncConfig c;
    c.history = 1000;  // not a power of two
    EXPECT_THROW(DesyncDetector(c, 2, 0, sim, ring, nullptr, stats), std::invalid_argument);
    c.history = 1;
    EXPECT_THROW(DesyncDetector(c, 2, 0, sim, ring, nullptr, stats), std::invalid_argument);
    c.history = 2;
    EXPECT_NO_THROW(DesyncDetector(c, 2, 0, sim, ring, nullptr, stats));
    EXPECT_GE(stats.peers.size(), 2u);
}

TEST(DesyncDetector, EqualChecksumsRaiseNoAlert) {
    Bare b(3);
    // Peer 1 reports after we confirmed, peer 2 before: both compared, all equal.
    for (std::uint32_t f = 0; f < 100; ++f) {
        b.detector.add_remote(2, f, sum(f));
        b.detector.add_local(f, sum(f));
        b.detector.add_remote(1, f, sum(f));
    }
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 100u);
    EXPECT_EQ(b.stats.peers[2].checksum_matches, 100u);
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches + b.stats.peers[2].checksum_mismatches, 0u);
    EXPECT_EQ(b.stats.desyncs, 0u);
    EXPECT_TRUE(b.recorder.desyncs.empty());
    EXPECT_TRUE(b.recorder.reports.empty());
    EXPECT_FALSE(b.detector.desynced(1));
    EXPECT_FALSE(b.detector.desynced(2));
    EXPECT_EQ(b.detector.newest_local(), 99u);
    EXPECT_EQ(b.detector.local_checksum(42), sum(42));
    EXPECT_EQ(b.detector.remote_checksum(1, 99), sum(99));
}

TEST(DesyncDetector, FirstMismatchIsReportedOnce) {
    Bare b;
    b.local(0, 49);
    for (std::uint32_t f = 0; f < 50; ++f) b.detector.add_remote(1, f, f < 20 ? sum(f) : other(f));
    ASSERT_EQ(b.recorder.desyncs.size(), 1u);  // not one per later differing frame
    const DesyncEvent& e = b.recorder.desyncs[0];
    EXPECT_EQ(e.peer, 1u);
    EXPECT_EQ(e.frame, 20u);
    EXPECT_EQ(e.local_checksum, sum(20));
    EXPECT_EQ(e.remote_checksum, other(20));
    EXPECT_TRUE(b.detector.desynced(1));
    EXPECT_EQ(b.stats.desyncs, 1u);
    // Every mismatch is counted, though only the first alerts.
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 20u);
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 30u);
    // No saved state here: the one report says so.
    ASSERT_EQ(b.recorder.reports.size(), 1u);
    EXPECT_EQ(b.recorder.reports[0].outcome, NarrowOutcome::EvidenceMissing);
    EXPECT_EQ(b.recorder.reports[0].detected_frame, 20u);
    EXPECT_FALSE(b.detector.investigating(1));
}

// Input messages carry the low 32 bits of a checksum (rollback/protocol.h): only those count.
TEST(DesyncDetector, ComparesTheLow32Bits) {
    Bare b;
    b.local(0, 3);
    b.detector.add_remote(1, 0, sum(0) & 0xFFFFFFFFull);
    b.detector.add_remote(1, 1, sum(1) ^ 0xFFFF'0000'0000'0000ull);
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 2u);
    b.detector.add_remote(1, 2, sum(2) ^ 1);
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 1u);
    EXPECT_EQ(b.recorder.desyncs.size(), 1u);
}

TEST(DesyncDetector, ReportsWaitForTheLocalFrameInAnyOrder) {
    Bare b;
    // The peer is ahead: frames 10..19 reported, shuffled, before we confirm any; from 15 on
    // they differ.
    for (const std::uint32_t f : {17u, 12u, 19u, 10u, 15u, 11u, 18u, 13u, 16u, 14u})
        b.detector.add_remote(1, f, f < 15 ? sum(f) : other(f));
    EXPECT_EQ(b.detector.remote_checksum(1, 17), other(17));  // waiting
    EXPECT_EQ(b.stats.peers[1].checksum_matches + b.stats.peers[1].checksum_mismatches, 0u);
    b.local(0, 14);
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 5u);
    EXPECT_TRUE(b.recorder.desyncs.empty());
    b.local(15, 30);
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 5u);
    ASSERT_EQ(b.recorder.desyncs.size(), 1u);
    EXPECT_EQ(b.recorder.desyncs[0].frame, 15u);  // the lowest, whatever the arrival order
}

TEST(DesyncDetector, RepeatsAndLateCopiesAreComparedOnce) {
    Bare b;
    b.local(0, 20);
    b.detector.add_remote(1, 5, sum(5));
    b.detector.add_remote(1, 5, sum(5));
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 1u);
    // A repeated mismatch alerts once and counts once.
    b.detector.add_remote(1, 8, other(8));
    b.detector.add_remote(1, 8, other(8));
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 1u);
    EXPECT_EQ(b.recorder.desyncs.size(), 1u);
    // A copy older than the newest compared frame is dropped (reordered datagram): frames in
    // between that went uncompared are what narrowing's first stage fetches.
    b.detector.add_remote(1, 6, other(6));
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 1u);
    // Repeats of a waiting report keep one entry (the latest copy).
    b.detector.add_remote(1, 25, sum(25));
    b.detector.add_remote(1, 25, sum(25));
    b.local(21, 25);
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 2u);
}

TEST(DesyncDetector, FramesOutsideTheRetainedWindowAreNotCompared) {
    DesyncConfig c;
    c.history = 16;
    c.max_pending_reports = 4;
    Bare b(2, c);
    b.local(0, 99);
    EXPECT_FALSE(b.detector.local_checksum(83).has_value());  // forgotten: 16 are kept
    EXPECT_EQ(b.detector.local_checksum(84), sum(84));
    // A report of a forgotten frame cannot be judged, so it is dropped, mismatch or not.
    b.detector.add_remote(1, 50, other(50));
    b.detector.add_remote(1, 83, sum(83));
    EXPECT_EQ(b.stats.peers[1].checksum_matches + b.stats.peers[1].checksum_mismatches, 0u);
    EXPECT_TRUE(b.recorder.desyncs.empty());
    b.detector.add_remote(1, 90, sum(90));
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 1u);
    // Reports ahead of us wait, at most max_pending_reports of them; the newest are dropped
    // first (including absurd ones), so the ones we confirm next are kept.
    for (const std::uint32_t f : {101u, 102u, 103u, 104u, 105u, 0xFFFFFFFFu, 1u << 30}) b.detector.add_remote(1, f, sum(f));
    EXPECT_TRUE(b.detector.remote_checksum(1, 104).has_value());
    EXPECT_FALSE(b.detector.remote_checksum(1, 105).has_value());
    EXPECT_FALSE(b.detector.remote_checksum(1, 0xFFFFFFFFu).has_value());
    b.local(100, 120);
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 5u);  // 90, then 101..104
    EXPECT_EQ(b.stats.peers[1].checksum_mismatches, 0u);
}

TEST(DesyncDetector, StrangersAreIgnored) {
    Bare b(3);
    b.local(0, 5);
    b.detector.add_remote(0, 3, other(3));   // ourselves
    b.detector.add_remote(3, 3, other(3));   // no such player
    b.detector.add_remote(200, 3, other(3));
    EXPECT_TRUE(b.recorder.desyncs.empty());
    EXPECT_FALSE(b.detector.remote_checksum(200, 3).has_value());
    ReplyMessage r;
    r.available = true;
    b.detector.on_reply(200, r);
    b.detector.reset_peer(200);
    b.detector.peer_failed(200);
    EXPECT_TRUE(b.recorder.reports.empty());
}

TEST(DesyncDetector, VerdictsArePerPeer) {
    Bare b(3);
    b.local(0, 40);
    for (std::uint32_t f = 0; f <= 40; ++f) {
        b.detector.add_remote(1, f, sum(f));
        b.detector.add_remote(2, f, f < 5 ? sum(f) : other(f));
    }
    EXPECT_FALSE(b.detector.desynced(1));
    EXPECT_TRUE(b.detector.desynced(2));
    ASSERT_EQ(b.recorder.desyncs.size(), 1u);
    EXPECT_EQ(b.recorder.desyncs[0].peer, 2u);
    EXPECT_EQ(b.recorder.desyncs[0].frame, 5u);
    EXPECT_EQ(b.stats.peers[1].checksum_matches, 41u);
    EXPECT_EQ(b.stats.peers[2].checksum_matches, 5u);
    EXPECT_EQ(b.stats.peers[2].checksum_mismatches, 36u);
    // Peer 1 diverging later is a desync of its own.
    b.local(41, 50);
    b.detector.add_remote(1, 45, other(45));
    ASSERT_EQ(b.recorder.desyncs.size(), 2u);
    EXPECT_EQ(b.recorder.desyncs[1].peer, 1u);
    EXPECT_EQ(b.recorder.desyncs[1].frame, 45u);
    EXPECT_EQ(b.stats.desyncs, 2u);
    // Peer 2's process is replaced: its verdict is forgotten, and it can alert again.
    b.detector.reset_peer(2);
    EXPECT_FALSE(b.detector.desynced(2));
    EXPECT_TRUE(b.detector.desynced(1));
    b.detector.add_remote(2, 48, sum(48));
    EXPECT_FALSE(b.detector.desynced(2));
    b.detector.add_remote(2, 49, other(49));
    ASSERT_EQ(b.recorder.desyncs.size(), 3u);
    EXPECT_EQ(b.recorder.desyncs[2].peer, 2u);
    EXPECT_EQ(b.recorder.desyncs[2].frame, 49u);
}

TEST(DesyncDetector, RestartForgetsEverythingBeforeTheSnapshot) {
    Bare b;
    b.local(0, 30);
    b.detector.add_remote(1, 10, other(10));
    ASSERT_TRUE(b.detector.desynced(1));
    b.detector.add_remote(1, 40, sum(40));  // waiting
    b.detector.restart_at(35, sum(35));
    EXPECT_FALSE(b.detector.desynced(1));
    EXPECT_FALSE(b.detector.local_checksum(30).has_value());
    EXPECT_EQ(b.detector.local_checksum(35), sum(35));
    EXPECT_FALSE(b.detector.remote_checksum(1, 40).has_value());
    b.detector.add_remote(1, 20, other(20));  // before the snapshot: ignored
    b.local(36, 40);
    b.detector.add_remote(1, 38, sum(38));
    EXPECT_FALSE(b.detector.desynced(1));
    b.detector.add_remote(1, 40, other(40));
    EXPECT_TRUE(b.detector.desynced(1));
    ASSERT_EQ(b.recorder.desyncs.size(), 2u);
    EXPECT_EQ(b.recorder.desyncs[1].frame, 40u);
}

// The whole narrowing: a bit flips in one body of one peer at frame 20; that peer announces its
// checksum every 8th frame only, so the mismatch is seen at 24 and the first stage has to find
// frame 20 among the uncompared 17..23, then the body, then the field.
TEST(DesyncDetector, NarrowsToTheFirstFrameBodyAndField) {
    constexpr std::uint32_t kFlipFrame = 20;
    // velocity.x of a falling ball: the difference lasts (a small flip of a resting body's
    // height can be absorbed by its contact within a step, and then no later frame differs).
    constexpr int kField = 3;
    constexpr int kBit = 24;
    Side a(0), b(1);
    ASSERT_GE(a.sim.body_count(), 4u);
    const std::uint32_t index = 3;
    const std::uint32_t body = b.sim.body_id(index);
    for (std::uint32_t f = 1; f <= 32; ++f) {
        a.confirm();
        if (f == kFlipFrame) {  // a fault injected as Sync does: into the state saved as frame f
            b.sim.step(std::vector<std::uint8_t>(2 * kWorldInputSize, 0));
            ++b.frame;
            ASSERT_TRUE(b.sim.flip_bit(body, kField, kBit));
            b.save(b.frame);
            b.detector.add_local(b.frame, b.checksum(b.frame));
        } else {
            b.confirm();
        }
        if (f % 8 == 0) a.detector.add_remote(1, f, b.checksum(f));
    }
    ASSERT_EQ(a.recorder.desyncs.size(), 1u);
    EXPECT_EQ(a.recorder.desyncs[0].frame, 24u);
    EXPECT_TRUE(a.detector.investigating(1));
    EXPECT_TRUE(a.recorder.reports.empty());
    std::uint64_t now = 0;
    for (int round = 0; round < 10 && a.detector.investigating(1); ++round, now += 1000) {
        const std::size_t sent = exchange(a, 1, b, now);
        EXPECT_GE(sent, 1u);
        EXPECT_LE(sent, 4u);  // max_outstanding
    }
    EXPECT_FALSE(a.detector.investigating(1));
    ASSERT_EQ(a.recorder.reports.size(), 1u);
    const DesyncReport& r = a.recorder.reports[0];
    EXPECT_EQ(r.outcome, NarrowOutcome::BodyNamed);
    EXPECT_EQ(r.peer, 1u);
    EXPECT_EQ(r.detected_frame, 24u);
    EXPECT_EQ(r.frame, kFlipFrame);
    EXPECT_EQ(r.local_checksum, a.checksum(kFlipFrame));
    EXPECT_EQ(r.remote_checksum, b.checksum(kFlipFrame));
    EXPECT_EQ(r.body_id, body);
    EXPECT_EQ(r.field, kField);
    EXPECT_EQ(r.field_name, a.sim.field_name(kField));
    EXPECT_EQ(static_cast<std::uint64_t>(r.local_value ^ r.remote_value), std::uint64_t{1} << kBit);
    EXPECT_EQ(r.local_value, a.sim.field_value(*a.ring.find(kFlipFrame), index, kField));
    const auto state = *a.ring.find(kFlipFrame);
    EXPECT_EQ(r.local_state, std::vector<std::uint8_t>(state.begin(), state.end()));
    EXPECT_NE(r.summary.find("first differing frame 20"), std::string::npos) << r.summary;
    EXPECT_NE(r.summary.find("body " + std::to_string(body)), std::string::npos) << r.summary;
    // The peer's whole checksum came in its reply, and the summary prints all 16 digits of it.
    EXPECT_TRUE(r.remote_checksum_full);
    char full[17];
    std::snprintf(full, sizeof full, "%016llx", static_cast<unsigned long long>(b.checksum(kFlipFrame)));
    EXPECT_NE(r.summary.find(std::string("peer ") + full), std::string::npos) << r.summary;
    // Nothing more is asked once the report is out.
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    a.detector.collect_queries(now + 1'000'000, out);
    EXPECT_TRUE(out.empty());
}

TEST(DesyncDetector, UnansweredQueriesAreResentThenGiveUp) {
    DesyncConfig c;
    c.resend_us = 1000;
    c.max_tries = 3;
    Side a(0, 2, c);
    for (int i = 0; i < 5; ++i) a.confirm();
    a.detector.add_remote(1, 0, a.checksum(0));
    a.detector.add_remote(1, 5, a.checksum(5) ^ 1);  // differs; 1..4 were never compared
    ASSERT_TRUE(a.detector.investigating(1));
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    a.detector.collect_queries(0, out);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].second.what, QueryWhat::FrameChecksums);
    EXPECT_EQ(out[0].second.frame, 1u);
    EXPECT_EQ(out[0].second.count, 4u);
    out.clear();
    a.detector.collect_queries(999, out);
    EXPECT_TRUE(out.empty());  // not due yet
    a.detector.collect_queries(1000, out);
    a.detector.collect_queries(2000, out);
    EXPECT_EQ(out.size(), 2u);  // tries 2 and 3
    EXPECT_TRUE(a.recorder.reports.empty());
    out.clear();
    a.detector.collect_queries(3000, out);
    EXPECT_TRUE(out.empty());
    EXPECT_FALSE(a.detector.investigating(1));
    ASSERT_EQ(a.recorder.reports.size(), 1u);
    EXPECT_EQ(a.recorder.reports[0].outcome, NarrowOutcome::NoReply);
    EXPECT_EQ(a.recorder.reports[0].frame, 5u);
    // Only an input message's 32 bits of the peer's checksum are known, and that is all the
    // summary claims (it once printed them as a 16-digit checksum with a zero high half).
    const DesyncReport& r = a.recorder.reports[0];
    EXPECT_FALSE(r.remote_checksum_full);
    char low[9];
    std::snprintf(low, sizeof low, "%08x", static_cast<unsigned>(static_cast<std::uint32_t>(r.remote_checksum)));
    EXPECT_NE(r.summary.find(std::string("peer ") + low + " (low 32 bits)"), std::string::npos) << r.summary;
}

// Recovery's arbitration needs every live player's checksum of the first differing frame; a
// peer whose input messages of that time were lost (a one-way cut) is asked for it: one
// FrameChecksums query of that frame, resent, answered into remote_checksum(). Unanswered after
// max_tries (the cut lasts), asking again re-arms it; a peer that lacks the frame is asked no more.
TEST(DesyncDetector, AskedChecksumOfAFrameIsQueriedResentAndRemembered) {
    DesyncConfig c;
    c.resend_us = 1000;
    c.max_tries = 2;
    Side a(0, 3, c);
    Side b(1, 3, c);
    for (int i = 0; i < 5; ++i) {
        a.confirm();
        b.confirm();
    }
    EXPECT_FALSE(a.detector.remote_checksum(1, 3));
    a.detector.ask_checksum(1, 3);
    a.detector.ask_checksum(1, 3);  // once per frame
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    a.detector.collect_queries(0, out);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].first, 1u);
    EXPECT_EQ(out[0].second.what, QueryWhat::FrameChecksums);
    EXPECT_EQ(out[0].second.frame, 3u);
    EXPECT_EQ(out[0].second.count, 1u);
    a.detector.collect_queries(500, out);
    EXPECT_EQ(out.size(), 1u) << "not due yet";
    a.detector.collect_queries(1000, out);
    a.detector.collect_queries(2000, out);
    EXPECT_EQ(out.size(), 2u) << "max_tries, then silent";
    a.detector.ask_checksum(1, 3);  // still wanted: asked again
    out.clear();
    a.detector.collect_queries(3000, out);
    ASSERT_EQ(out.size(), 1u);
    a.detector.on_reply(1, b.detector.answer(out[0].second));
    EXPECT_EQ(a.detector.remote_checksum(1, 3), b.checksum(3));
    EXPECT_FALSE(a.detector.investigating(1)) << "an answer is no investigation";
    out.clear();
    a.detector.collect_queries(10'000, out);
    EXPECT_TRUE(out.empty()) << "answered: asked no more";
    // A frame the peer no longer holds: "unavailable", asked no more, still unknown.
    a.detector.ask_checksum(2, 4000);
    a.detector.collect_queries(10'000, out);
    ASSERT_EQ(out.size(), 1u);
    a.detector.on_reply(2, b.detector.answer(out[0].second));
    EXPECT_FALSE(a.detector.remote_checksum(2, 4000));
    out.clear();
    a.detector.collect_queries(20'000, out);
    EXPECT_TRUE(out.empty());
    EXPECT_TRUE(a.recorder.desyncs.empty());
}

TEST(DesyncDetector, InvestigationEndsWhenThePeerFailsOrLacksEvidence) {
    Side a(0);
    for (int i = 0; i < 5; ++i) a.confirm();
    a.detector.add_remote(1, 5, a.checksum(5) ^ 1);
    ASSERT_TRUE(a.detector.investigating(1));
    a.detector.peer_failed(1);
    ASSERT_EQ(a.recorder.reports.size(), 1u);
    EXPECT_EQ(a.recorder.reports[0].outcome, NarrowOutcome::NoReply);
    a.detector.peer_failed(1);  // once is enough
    EXPECT_EQ(a.recorder.reports.size(), 1u);

    Side c(0, 3);
    for (int i = 0; i < 5; ++i) c.confirm();
    c.detector.add_remote(2, 5, c.checksum(5) ^ 1);
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    c.detector.collect_queries(0, out);
    ASSERT_EQ(out.size(), 1u);
    // A reply to something else is ignored; the peer saying it lacks the frame ends it.
    ReplyMessage stray;
    stray.what = out[0].second.what;
    stray.frame = out[0].second.frame + 1;
    stray.count = out[0].second.count;
    stray.available = true;
    c.detector.on_reply(2, stray);
    EXPECT_TRUE(c.detector.investigating(2));
    ReplyMessage lacks;
    lacks.what = out[0].second.what;
    lacks.frame = out[0].second.frame;
    lacks.start = out[0].second.start;
    lacks.count = out[0].second.count;
    lacks.available = false;
    c.detector.on_reply(2, lacks);
    EXPECT_FALSE(c.detector.investigating(2));
    ASSERT_EQ(c.recorder.reports.size(), 1u);
    EXPECT_EQ(c.recorder.reports[0].outcome, NarrowOutcome::EvidenceMissing);
}

TEST(DesyncDetector, AtMostMaxOutstandingQueriesInFlight) {
    DesyncConfig c;
    c.max_outstanding = 2;
    c.max_pinned_frames = 400;
    Side a(0, 2, c, 512);
    for (int i = 0; i < 400; ++i) a.confirm();
    a.detector.add_remote(1, 0, a.checksum(0));
    a.detector.add_remote(1, 399, a.checksum(399) ^ 1);  // 1..398 uncompared: 4 chunks of <= 128
    std::vector<std::pair<PlayerId, QueryMessage>> out;
    a.detector.collect_queries(0, out);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(out[0].second.frame, 1u);
    EXPECT_EQ(out[0].second.count, kMaxQueryItems);
    EXPECT_EQ(out[1].second.frame, 1u + kMaxQueryItems);
    // Answering the first (all equal to ours) lets the third go out.
    ReplyMessage r = a.detector.answer(out[0].second);
    ASSERT_TRUE(r.available);
    a.detector.on_reply(1, r);
    out.clear();
    a.detector.collect_queries(1, out);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].second.frame, 1u + 2u * kMaxQueryItems);
}

// Queries come off the network: nonsense gets an "unavailable" reply, never a crash.
TEST(DesyncDetector, AnswersHostileQueriesWithUnavailable) {
    Side a(0);
    for (int i = 0; i < 10; ++i) a.confirm();
    const std::uint32_t bodies = a.sim.body_count();
    const auto unavailable = [&](QueryWhat what, std::uint32_t frame, std::uint32_t start, std::uint16_t count) {
        const ReplyMessage r = a.detector.answer({what, frame, start, count});
        return !r.available && r.values.empty() && r.fields.empty();
    };
    EXPECT_TRUE(unavailable(QueryWhat::FrameChecksums, 5, 0, 7));     // 5..10 held, 11 not yet
    EXPECT_TRUE(unavailable(QueryWhat::FrameChecksums, 0xFFFFFFF0u, 0, 0xFFFF));
    EXPECT_TRUE(unavailable(QueryWhat::BodyHashes, 11, 0, 1));        // no such frame yet
    EXPECT_TRUE(unavailable(QueryWhat::BodyHashes, 5, bodies, 1));    // no such body
    EXPECT_TRUE(unavailable(QueryWhat::BodyHashes, 5, 1, static_cast<std::uint16_t>(bodies)));
    EXPECT_TRUE(unavailable(QueryWhat::BodyHashes, 5, 0xFFFFFFFFu, 0xFFFF));
    EXPECT_TRUE(unavailable(QueryWhat::BodyFields, 5, bodies, 1));
    EXPECT_TRUE(unavailable(QueryWhat::BodyFields, 0xFFFFFFFFu, 0, 1));
    // The sane versions of the same questions are answered from our evidence.
    const ReplyMessage sums = a.detector.answer({QueryWhat::FrameChecksums, 5, 0, 5});
    ASSERT_TRUE(sums.available);
    ASSERT_EQ(sums.values.size(), 5u);
    for (std::uint32_t k = 0; k < 5; ++k) EXPECT_EQ(sums.values[k], a.checksum(5 + k));
    const ReplyMessage hashes = a.detector.answer({QueryWhat::BodyHashes, 5, 0, static_cast<std::uint16_t>(bodies)});
    ASSERT_TRUE(hashes.available);
    ASSERT_EQ(hashes.values.size(), bodies);
    EXPECT_EQ(hashes.values[2], a.sim.body_hash(*a.ring.find(5), 2));
    const ReplyMessage fields = a.detector.answer({QueryWhat::BodyFields, 5, 2, 1});
    ASSERT_TRUE(fields.available);
    EXPECT_EQ(fields.fields.size(), static_cast<std::size_t>(a.sim.field_count()));
    EXPECT_EQ(fields.fields[0], a.sim.field_value(*a.ring.find(5), 2, 0));
}

}  // namespace
}  // namespace lockroll::rollback

namespace lockroll::rollback {
namespace {

// A rigid scene with rigid.sleeping: the state words per body include the sleep word (field 13,
// "sleep"), and the state dump prints it as the count it is (no Q32.32 decimal).
TEST(DesyncDetector, SleepingScenesNameAndPrintTheSleepWord) {
    sim::SceneDesc scene = make_scene(2, 0);
    scene.rigid.enabled = true;
    scene.rigid.sleeping.enabled = true;
    WorldSimulation sim(scene, 2);
    ASSERT_EQ(sim.field_count(), 14);
    EXPECT_STREQ(sim.field_name(13), "sleep");
    std::vector<std::uint8_t> state(sim.state_size());
    sim.save(state);
    const std::string text = sim.describe_state(state);
    EXPECT_NE(text.find(" angular_velocity.z sleep  ("), std::string::npos) << text;
    // Every body starts with a count of 0: each line ends " 0".
    const std::size_t line = text.find('\n', text.find("(Q32.32 raw")) + 1;
    const std::string first = text.substr(line, text.find('\n', line) - line);
    EXPECT_EQ(first.substr(first.size() - 2), " 0") << first;
}

}  // namespace
}  // namespace lockroll::rollback
