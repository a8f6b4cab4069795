// SnapshotVetting on its own (a strict majority of the view, the two-player rule, answers that do
// not count, the deadline that rejects a minority),
// and in virtual time the attack it stops (issue 21, "a joiner trusts any snapshot"): a peer
// whose state is wrong serves a snapshot whose hash matches its bytes; the newcomer asks the
// others for their confirmed checksum of that frame, rejects it, asks another host, and ends on
// the honest final.
#include <gtest/gtest.h>

#include <vector>

#include "rollback/session.h"
#include "rollback/snapshot_vetting.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {
namespace {

using V = SnapshotVetting::Verdict;

// A view of `players` slots seen from `local` (a slot, or a spectator id past them); the slots
// in `down` are disconnected.
Membership view(int players, PlayerId local, std::vector<PlayerId> down = {},
                TwoPlayerRule rule = TwoPlayerRule::PlayOnAlone) {
    Membership m(players, local, rule);
    for (PlayerId s : down) m.leave(s);
    return m;
}

// A spectator of three players: three running processes, two needed.
TEST(SnapshotVetting, AMajorityOfAgreeingAnswersAccepts) {
    SnapshotVetting v;
    v.start(100, 0xAB, 0, view(3, 3), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 2);
    EXPECT_EQ(v.verdict(0), V::Pending);
    v.on_reply(0, 100, true, 0xAB);
    EXPECT_EQ(v.verdict(0), V::Pending) << "the provider's word alone is not a majority of three";
    v.on_reply(2, 100, true, 0xAB);
    EXPECT_EQ(v.verdict(0), V::Accepted);
    EXPECT_NE(v.detail(0).find("2 agree, 0 differ, 2 needed of the view's 3 running processes"), std::string::npos)
        << v.detail(0);
}

TEST(SnapshotVetting, DisagreeingAnswersThatLeaveNoMajorityReject) {
    SnapshotVetting v;
    v.start(100, 0xAB, 0, view(3, 3), 0, 1'000'000);
    v.on_reply(0, 100, true, 0xAB);
    v.on_reply(1, 100, true, 0xCD);
    EXPECT_EQ(v.verdict(0), V::Pending) << "2 could still agree";
    v.on_reply(2, 100, true, 0xCD);
    EXPECT_EQ(v.verdict(0), V::Rejected);
    EXPECT_NE(v.detail(0).find("peer 1 confirmed 00000000000000cd"), std::string::npos) << v.detail(0);
}

TEST(SnapshotVetting, AnswersThatDoNotCount) {
    SnapshotVetting v;
    v.start(100, 0xAB, 0, view(3, 3), 0, 1'000'000);
    v.on_reply(7, 100, true, 0xAB);   // not a voter
    v.on_reply(1, 99, true, 0xAB);    // another frame
    v.on_reply(1, 100, false, 0xAB);  // not available: no answer, asked again
    v.on_reply(0, 100, true, 0xAB);
    v.on_reply(0, 100, true, 0xAB);   // twice: one answer
    EXPECT_EQ(v.verdict(0), V::Pending);
    std::vector<PlayerId> ask;
    v.due(0, 100, ask);
    EXPECT_EQ(ask, (std::vector<PlayerId>{1, 2}));
    v.due(50, 100, ask);
    EXPECT_TRUE(ask.empty()) << "not before the resend time";
    v.due(100, 100, ask);
    EXPECT_EQ(ask, (std::vector<PlayerId>{1, 2}));
}

// A joiner in slot 2 of three whose slot runs (handed over): the view has three running
// processes, so two of the other two must agree -- the provider and one more.
TEST(SnapshotVetting, TheProviderAndOneAgreeingOfAViewOfThreeAccepts) {
    SnapshotVetting v;
    v.start(100, 0xAB, 0, view(3, 2), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 2);
    std::vector<PlayerId> ask;
    v.due(0, 100, ask);
    EXPECT_EQ(ask, (std::vector<PlayerId>{0, 1})) << "the joiner does not ask itself";
    v.on_reply(0, 100, true, 0xAB);
    EXPECT_EQ(v.verdict(999'999), V::Pending);
    v.on_reply(1, 100, true, 0xAB);
    EXPECT_EQ(v.verdict(999'999), V::Accepted);
    EXPECT_EQ(v.detail(0).find("two-player"), std::string::npos) << v.detail(0);
    // Its slot not running: it is no voter of the view, and the two others are a view of two
    // with a majority of distinct others (both); the two-player rule has nothing to decide.
    v.start(100, 0xAB, 0, view(3, 2, {2}), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 2);
    v.on_reply(0, 100, true, 0xAB);
    EXPECT_EQ(v.verdict(1'000'000), V::Rejected);
    // A view of four with the joiner's slot disconnected: three running, two needed.
    v.start(100, 0xAB, 0, view(4, 3, {3}), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 2);
}

// A view of two with the joiner in it: the provider is the only other voter, no majority of
// distinct others exists, and the configured two-player rule decides, as for drops.
TEST(SnapshotVetting, AViewOfTwoFollowsTheTwoPlayerRuleAndNamesIt) {
    SnapshotVetting v;
    v.start(40, 0x11, 0, view(2, 1), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 1);
    EXPECT_EQ(v.verdict(0), V::Pending);
    v.on_reply(0, 40, true, 0x11);
    EXPECT_EQ(v.verdict(0), V::Accepted);
    EXPECT_NE(v.detail(0).find("the two-player rule play_on_alone lets the provider's word decide"), std::string::npos)
        << v.detail(0);
    // Still checked: a provider whose own checksum differs from its snapshot's is rejected.
    v.start(40, 0x11, 0, view(2, 1), 0, 1'000'000);
    v.on_reply(0, 40, true, 0x12);
    EXPECT_EQ(v.verdict(0), V::Rejected);
    // NoDrop: one voter's word never decides, so such a snapshot is never loaded.
    v.start(40, 0x11, 0, view(2, 1, {}, TwoPlayerRule::NoDrop), 0, 1'000'000);
    EXPECT_EQ(v.needed(), 2);
    v.on_reply(0, 40, true, 0x11);
    EXPECT_EQ(v.verdict(0), V::Rejected);
    EXPECT_NE(v.detail(0).find("the two-player rule no_drop does not let"), std::string::npos) << v.detail(0);
    // A three-player match down to one survivor and the joiner: the same view of two.
    v.start(40, 0x11, 0, view(3, 2, {1}), 0, 1'000'000);
    v.on_reply(0, 40, true, 0x11);
    EXPECT_EQ(v.verdict(0), V::Accepted);
}

// Before, the provider's own answer with the others silent was accepted at the deadline ("some
// agree, nobody differs"): one peer's word loaded a snapshot in a view of three.
TEST(SnapshotVetting, AtTheDeadlineTheProviderAloneIsRejectedAndTheSilentAreNamed) {
    SnapshotVetting v;
    v.start(10, 0x1, 0, view(3, 3), 0, 1000);
    v.on_reply(0, 10, true, 0x1);
    EXPECT_EQ(v.verdict(999), V::Pending);
    EXPECT_EQ(v.verdict(1000), V::Rejected) << "silence is no agreement";
    EXPECT_NE(v.detail(1000).find("cut off from a majority of the view: no answer in time from peer 1, 2"),
              std::string::npos)
        << v.detail(1000);
    EXPECT_EQ(v.detail(999).find("cut off"), std::string::npos) << "not before the deadline";
    // The same voters as a list, for the joiner's reach (rollback/joiner_reach.h).
    EXPECT_EQ(v.silent(1000), (std::vector<PlayerId>{1, 2}));
    EXPECT_TRUE(v.silent(999).empty()) << "not before the deadline";
    v.start(10, 0x1, 0, view(3, 3), 0, 1000);
    EXPECT_EQ(v.verdict(1000), V::Rejected) << "nobody answered";
    EXPECT_EQ(v.silent(1000), (std::vector<PlayerId>{0, 1, 2}));
    v.start(10, 0x1, 0, view(3, 3), 0, 1000);
    v.on_reply(0, 10, true, 0x1);
    v.on_reply(1, 10, true, 0x2);
    EXPECT_EQ(v.verdict(1000), V::Rejected) << "one differs";
    EXPECT_EQ(v.silent(1000), std::vector<PlayerId>{2});
    v.on_reply(2, 10, true, 0x2);
    EXPECT_TRUE(v.silent(1000).empty()) << "rejected by the answers: nobody silent";
    v.reset();
    EXPECT_FALSE(v.active());
}

// A spectator is no member of the view and between processes reaches only its host: past the
// deadline its host's uncontested word is enough (said in the detail), a differing answer still
// rejects, and before the deadline a majority decides as for a joiner.
TEST(SnapshotVetting, AtTheDeadlineASpectatorTakesItsHostsUncontestedWord) {
    using A = SnapshotVetting::AtDeadline;
    SnapshotVetting v;
    v.start(10, 0x1, 0, view(3, 3), 0, 1000, A::AcceptUncontested);
    v.on_reply(0, 10, true, 0x1);
    EXPECT_EQ(v.verdict(999), V::Pending);
    EXPECT_EQ(v.verdict(1000), V::Accepted);
    EXPECT_TRUE(v.silent(1000).empty()) << "accepted: nobody is named cut off";
    EXPECT_NE(v.detail(1000).find("a spectator: accepted uncontested, no answer in time from peer 1, 2"),
              std::string::npos)
        << v.detail(1000);
    v.start(10, 0x1, 0, view(3, 3), 0, 1000, A::AcceptUncontested);
    v.on_reply(0, 10, true, 0x1);
    v.on_reply(1, 10, true, 0x2);
    EXPECT_EQ(v.verdict(1000), V::Rejected) << "one differs";
    v.start(10, 0x1, 0, view(3, 3), 0, 1000, A::AcceptUncontested);
    EXPECT_EQ(v.verdict(1000), V::Rejected) << "nobody answered";
}

using testing::Client;
using testing::Cluster;
using testing::make_scene;
using Kind = SessionEvent::Kind;

// Slot 0's state goes wrong at frame 120 (a flipped bit, no recovery): from then on each of its
// snapshots is consistent -- the hash matches the bytes -- but wrong. A spectator asks slot 0
// first (the lowest host); before, it loaded that state and followed the wrong match.
TEST(SnapshotVetting, ForgedSnapshotIsRejectedAndTheSpectatorEndsOnTheHonestFinal) {
    const auto scene = make_scene(3, 20);
    SessionConfig cfg = testing::real_config(3, 8);
    cfg.max_spectators = 1;
    Cluster cluster(scene, cfg, {15000, 3000}, 9);
    cluster.run_frames(60);
    const std::uint32_t body = cluster.clients[0]->sim.body_id(5);
    ASSERT_EQ(cluster.clients[0]->session->inject_fault(120, body, 0, 20), "");
    cluster.run_frames(300, 30'000'000);
    Client& spectator = testing::start_newcomer(cluster, scene, cfg, Role::Spectator, 3, 1);
    cluster.run_frames(700, 60'000'000);
    cluster.settle(700);
    ASSERT_EQ(spectator.session->phase(), SessionPhase::Running) << spectator.session->failure();
    std::vector<const SessionEvent*> rejected, loaded;
    for (const SessionEvent& e : spectator.events) {
        if (e.kind == Kind::SnapshotRejected) rejected.push_back(&e);
        if (e.kind == Kind::SnapshotLoaded) loaded.push_back(&e);
    }
    ASSERT_GE(rejected.size(), 1u);
    EXPECT_EQ(rejected[0]->peer, 0u) << "slot 0 served the forged snapshot";
    EXPECT_NE(rejected[0]->detail.find("differ"), std::string::npos) << rejected[0]->detail;
    ASSERT_EQ(loaded.size(), 1u);
    EXPECT_NE(loaded[0]->peer, 0u) << "loaded from an honest host";
    EXPECT_NE(loaded[0]->detail.find("agree"), std::string::npos) << loaded[0]->detail;
    // The spectator follows the honest players (1 and 2), not slot 0's wrong state.
    const auto honest = cluster.clients[1]->confirmed.find(700);
    const auto mine = spectator.confirmed.find(700);
    ASSERT_NE(honest, cluster.clients[1]->confirmed.end());
    ASSERT_NE(mine, spectator.confirmed.end());
    EXPECT_EQ(mine->second, honest->second);
    EXPECT_EQ(cluster.clients[2]->confirmed.at(700), honest->second);
    EXPECT_NE(cluster.clients[0]->confirmed.at(700), honest->second) << "slot 0 really was wrong";
}

}  // namespace
}  // namespace lockroll::rollback
