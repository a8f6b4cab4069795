// DropAgreement (rollback/drop_agreement.h) on its own: a drop is chosen by a majority of the
// view before anyone applies it; one instance chooses one slot, whatever order reports arrive in.
#include "rollback/drop_agreement.h"

#include <gtest/gtest.h>

#include <map>
#include <optional>
#include <random>
#include <set>
#include <vector>

namespace lockroll::rollback {
namespace {

constexpr std::uint64_t kRetry = 500'000;

// One process: its view (with its own votes) and its side of the agreement.
struct Node {
    Membership view;
    DropAgreement agreement;
    Node(int players, PlayerId local) : view(players, local, TwoPlayerRule::PlayOnAlone), agreement(players, local) {}
    // What the session passes as `wanted`: a slot a majority votes gone, our own vote among them.
    PlayerId wanted() const {
        for (PlayerId s = 0; s < static_cast<PlayerId>(view.players()); ++s)
            if (s != view.local() && view.decided_gone(s) && view.vote_of(view.local(), s) == Vote::Gone) return s;
        return kNoSlot;
    }
    std::optional<PlayerId> step(std::uint64_t now_us) { return agreement.step(view, wanted(), now_us, kRetry); }
};

// Each node hears every other's report (and its votes), then steps, until nothing changes.
std::map<PlayerId, PlayerId> gossip(std::vector<Node>& nodes, std::uint64_t now_us, int rounds = 8) {
    std::map<PlayerId, PlayerId> chosen;
    for (int r = 0; r < rounds; ++r)
        for (std::size_t i = 0; i < nodes.size(); ++i) {
            if (chosen.count(static_cast<PlayerId>(i))) continue;
            for (std::size_t j = 0; j < nodes.size(); ++j)
                if (j != i) nodes[i].agreement.heard(static_cast<PlayerId>(j), nodes[j].agreement.report());
            if (const auto x = nodes[i].step(now_us)) chosen[static_cast<PlayerId>(i)] = *x;
        }
    return chosen;
}

// Everyone but `dead` votes it gone, at every node.
void all_vote_gone(std::vector<Node>& nodes, PlayerId dead) {
    for (auto& n : nodes)
        for (std::size_t v = 0; v < nodes.size(); ++v)
            if (v != dead) n.view.vote(static_cast<PlayerId>(v), dead, Vote::Gone, static_cast<std::uint8_t>(n.view.epoch(dead) + 1));
}

TEST(DropAgreement, AKilledSlotIsChosenByTheOthersAndNothingBeforeAMajorityAccepted) {
    std::vector<Node> nodes;
    for (PlayerId p = 0; p < 3; ++p) nodes.emplace_back(3, p);
    all_vote_gone(nodes, 2);
    // Node 0 alone: it proposes, but no slot is named before a majority promised, and nothing
    // is chosen on its own acceptance.
    EXPECT_FALSE(nodes[0].step(0));
    EXPECT_NE(nodes[0].agreement.report().proposal, 0);
    EXPECT_EQ(nodes[0].agreement.report().proposal_slot, kNoSlot);
    EXPECT_EQ(ballot_proposer(nodes[0].agreement.report().proposal), 0u);
    EXPECT_TRUE(nodes[0].agreement.active());
    nodes[1].agreement.heard(0, nodes[0].agreement.report());
    EXPECT_FALSE(nodes[1].step(0));
    EXPECT_EQ(nodes[1].agreement.report().promised, nodes[0].agreement.report().proposal) << "node 1 promised node 0's ballot";
    nodes[0].agreement.heard(1, nodes[1].agreement.report());
    EXPECT_FALSE(nodes[0].step(0)) << "named and accepted by node 0 alone: not chosen yet";
    EXPECT_EQ(nodes[0].agreement.report().proposal_slot, 2u);
    EXPECT_EQ(nodes[0].agreement.report().accepted_slot, 2u);
    nodes[1].agreement.heard(0, nodes[0].agreement.report());
    EXPECT_EQ(nodes[1].step(0), std::optional<PlayerId>(2)) << "node 1 accepted too: 2 of 3";
    nodes[0].agreement.heard(1, nodes[1].agreement.report());
    EXPECT_EQ(nodes[0].step(0), std::optional<PlayerId>(2));
    EXPECT_EQ(nodes[0].agreement.backing(nodes[0].view, 2), 2);
}

TEST(DropAgreement, AProposerAloneDropsNobody) {
    // Node 0 wants slot 2 gone; nodes 1 and 2 hear it fine and never accept: a forged or stale
    // proposal costs promises, not a player.
    std::vector<Node> nodes;
    for (PlayerId p = 0; p < 3; ++p) nodes.emplace_back(3, p);
    nodes[0].view.vote_local(2, true);
    nodes[0].view.vote(1, 2, Vote::Gone, 1);  // a stale vote from node 1, as node 0 last heard it
    const auto chosen = gossip(nodes, 0);
    EXPECT_TRUE(chosen.empty());
    EXPECT_EQ(nodes[0].agreement.report().proposal_slot, 2u) << "node 0 named it";
    EXPECT_EQ(nodes[1].agreement.report().accepted, 0) << "node 1 does not say 2 is gone";
    EXPECT_EQ(nodes[2].agreement.report().accepted, 0);
}

// drop_agreement_fuzz found it: a hostile voter (2, whom 0 and 1 vote gone) answers 0's ballot
// with a promise and an acceptance of slot 1 under that very ballot. 0 must carry slot 1
// forward (Paxos) but never accepts it on 2's word, so 1, which nobody votes gone, stays.
TEST(DropAgreement, AHostileVotersForgedAcceptanceDropsNobodyElse) {
    std::vector<Node> nodes;
    for (PlayerId p = 0; p < 3; ++p) nodes.emplace_back(3, p);
    for (PlayerId p : {0u, 1u})
        for (PlayerId v : {0u, 1u}) nodes[p].view.vote(v, 2, Vote::Gone, 1);
    EXPECT_FALSE(nodes[0].step(0));
    const std::uint16_t ballot = nodes[0].agreement.report().proposal;
    ASSERT_NE(ballot, 0);
    AgreementReport forged;
    forged.instance = nodes[0].view.view_id();
    forged.promised = forged.accepted = ballot;
    forged.accepted_slot = 1;
    for (PlayerId p : {0u, 1u}) nodes[p].agreement.heard(2, forged);
    for (int i = 0; i < 4; ++i) {
        EXPECT_FALSE(nodes[0].step(static_cast<std::uint64_t>(i))) << "step " << i;
        nodes[1].agreement.heard(0, nodes[0].agreement.report());
        EXPECT_FALSE(nodes[1].step(static_cast<std::uint64_t>(i))) << "step " << i;
        nodes[0].agreement.heard(1, nodes[1].agreement.report());
    }
    EXPECT_EQ(nodes[0].agreement.report().proposal_slot, 1u) << "carried forward, as Paxos must";
    EXPECT_NE(nodes[0].agreement.report().accepted_slot, 1u) << "but not accepted on one voter's word";
    EXPECT_NE(nodes[1].agreement.report().accepted_slot, 1u);
}

TEST(DropAgreement, ABallotInAnothersNameIsIgnored) {
    Node n(3, 0);
    AgreementReport forged;
    forged.instance = n.view.view_id();
    forged.proposal = make_ballot(7, 2);  // sent by 1 in 2's name
    forged.proposal_slot = 2;
    n.agreement.heard(1, forged);
    EXPECT_FALSE(n.step(0));
    EXPECT_EQ(n.agreement.report().promised, 0) << "no promise to a ballot its sender cannot make";
}

TEST(DropAgreement, AnAcceptedSlotIsCarriedForwardByTheNextBallot) {
    // Node 1 accepted slot 3 under node 2's ballot (node 2 then fell silent). Node 0 now wants
    // slot 2 gone: a majority's promises include node 1's acceptance, so node 0 must name 3.
    std::vector<Node> nodes;
    for (PlayerId p = 0; p < 4; ++p) nodes.emplace_back(4, p);
    AgreementReport accepted;
    accepted.instance = nodes[1].view.view_id();
    accepted.proposal = accepted.promised = make_ballot(1, 2);
    accepted.proposal_slot = 3;
    nodes[1].view.vote_local(3, true);
    nodes[1].agreement.heard(2, accepted);
    nodes[1].step(0);
    ASSERT_EQ(nodes[1].agreement.report().accepted_slot, 3u);
    for (auto* n : {&nodes[0], &nodes[3]})
        for (PlayerId v : {0u, 1u, 3u}) n->view.vote(v, 2, Vote::Gone, 1);
    nodes[1].view.vote(0, 2, Vote::Gone, 1);
    nodes[1].view.vote(3, 2, Vote::Gone, 1);
    nodes[0].view.vote_local(2, true);
    ASSERT_EQ(nodes[0].wanted(), 2u);
    nodes[0].agreement.heard(1, nodes[1].agreement.report());  // its ballot goes above node 2's
    nodes[0].step(0);
    for (PlayerId p : {1u, 3u}) {
        nodes[p].agreement.heard(0, nodes[0].agreement.report());
        nodes[p].step(0);
        nodes[0].agreement.heard(p, nodes[p].agreement.report());
    }
    nodes[0].step(0);
    EXPECT_EQ(nodes[0].agreement.report().proposal_slot, 3u) << "a slot a majority may have chosen is never replaced";
}

TEST(DropAgreement, AViewOfTwoIsLeftToTheTwoPlayerRule) {
    Node n(2, 0);
    n.view.vote_local(1, true);
    AgreementReport r;
    r.instance = n.view.view_id();
    r.accepted = r.promised = make_ballot(1, 1);
    r.accepted_slot = 1;
    n.agreement.heard(1, r);
    EXPECT_FALSE(n.step(0)) << "no majority of two: MembershipChanges decides by the rule";
}

TEST(DropAgreement, ANewViewIsANewInstance) {
    std::vector<Node> nodes;
    for (PlayerId p = 0; p < 3; ++p) nodes.emplace_back(3, p);
    all_vote_gone(nodes, 2);
    nodes[0].step(0);
    const std::uint32_t before = nodes[0].agreement.instance();
    EXPECT_EQ(before, nodes[0].view.view_id());
    nodes[0].view.hand_over(1, 1);  // a join changes the view
    nodes[0].step(1);
    EXPECT_NE(nodes[0].agreement.instance(), before);
    EXPECT_EQ(nodes[0].agreement.instance(), nodes[0].view.view_id());
    // A report of the old instance counts no more.
    AgreementReport old;
    old.instance = before;
    old.accepted = old.promised = make_ballot(3, 1);
    old.accepted_slot = 2;
    nodes[0].agreement.heard(1, old);
    EXPECT_EQ(nodes[0].agreement.backing(nodes[0].view, 2), nodes[0].agreement.report().accepted_slot == 2 ? 1 : 0);
}

TEST(DropAgreement, DropsAMajorityAppliedAreLearned) {
    // A process cut off while the others agreed learns the drop from their tables.
    Node n(5, 0);
    n.agreement.heard_drop(1, 4, 1);
    n.agreement.heard_drop(2, 4, 1);
    EXPECT_FALSE(n.step(0)) << "two of five";
    n.agreement.heard_drop(3, 4, 0);  // about an older epoch: says nothing
    EXPECT_FALSE(n.step(0));
    n.agreement.heard_drop(3, 4, 1);
    EXPECT_EQ(n.step(0), std::optional<PlayerId>(4));
    n.agreement.forget(3);
    EXPECT_FALSE(n.step(0)) << "a new process in slot 3: its predecessor's word is void";
}

// Safety under any interleaving: nodes vote and withdraw at random, reports arrive late, out of
// order or never, proposers retry; every node that decides in the starting view decides the same
// slot (the split the freeze tests found could not happen here).
TEST(DropAgreement, OneViewChoosesOneSlotUnderAnyInterleaving) {
    int decided_runs = 0;
    for (int players : {3, 4, 5, 7}) {
        for (std::uint32_t seed = 1; seed <= 400; ++seed) {
            std::mt19937 rng(seed * 7919u + static_cast<std::uint32_t>(players));
            std::vector<Node> nodes;
            for (PlayerId p = 0; p < static_cast<PlayerId>(players); ++p) nodes.emplace_back(players, p);
            const std::uint32_t start = nodes[0].view.view_id();
            // Snapshots of reports in flight: (to, from, report), delivered late or never.
            struct Flight {
                PlayerId to, from;
                AgreementReport r;
            };
            std::vector<Flight> flights;
            std::map<PlayerId, PlayerId> chosen;
            std::uint64_t now = 0;
            for (int step = 0; step < 600; ++step) {
                now += 10'000;
                const auto i = static_cast<PlayerId>(rng() % static_cast<unsigned>(players));
                Node& n = nodes[i];
                // Votes change at random (silence, hearing again), and travel at once.
                if (rng() % 4 == 0) {
                    const auto s = static_cast<PlayerId>(rng() % static_cast<unsigned>(players));
                    const bool gone = rng() % 2 == 0;
                    if (s != i)
                        for (Node& m : nodes)
                            if (m.view.view_id() == start)
                                m.view.vote(i, s, gone ? Vote::Gone : Vote::Runs, static_cast<std::uint8_t>(gone ? 1 : 0));
                }
                // Deliver some flights to i, in any order, some lost.
                std::shuffle(flights.begin(), flights.end(), rng);
                for (auto it = flights.begin(); it != flights.end();) {
                    if (it->to == i && rng() % 3 != 0) {
                        if (rng() % 5 != 0) n.agreement.heard(it->from, it->r);
                        it = flights.erase(it);
                    } else {
                        ++it;
                    }
                }
                if (chosen.count(i)) continue;
                if (const auto x = n.step(now)) {
                    chosen[i] = *x;
                    continue;  // it applies the drop: a new view, out of this instance
                }
                for (PlayerId to = 0; to < static_cast<PlayerId>(players); ++to)
                    if (to != i && flights.size() < 4000) flights.push_back({to, i, n.agreement.report()});
            }
            std::set<PlayerId> slots;
            for (const auto& [node, slot] : chosen) slots.insert(slot);
            EXPECT_LE(slots.size(), 1u) << players << " players, seed " << seed;
            decided_runs += !chosen.empty();
        }
    }
    EXPECT_GT(decided_runs, 200) << "the interleavings must also decide, or the test proves nothing";
}

TEST(DropAgreement, EveryLiveNodeDecidesAKilledSlot) {
    for (int players : {3, 4, 5, 8}) {
        std::vector<Node> nodes;
        for (PlayerId p = 0; p < static_cast<PlayerId>(players); ++p) nodes.emplace_back(players, p);
        const auto dead = static_cast<PlayerId>(players - 1);
        all_vote_gone(nodes, dead);
        std::vector<Node> live(nodes.begin(), nodes.end() - 1);
        // The dead node says nothing: the live ones gossip among themselves.
        const auto chosen = gossip(live, 0);
        EXPECT_EQ(chosen.size(), live.size()) << players << " players";
        for (const auto& [node, slot] : chosen) EXPECT_EQ(slot, dead) << "node " << node;
    }
}

}  // namespace
}  // namespace lockroll::rollback
