#include "rollback/drop_agreement.h"

#include <algorithm>


namespace lockroll::rollback {

DropAgreement::DropAgreement(int players, PlayerId local) : players_(players > 0 ? players : 0), local_(local) {
    heard_.assign(static_cast<std::size_t>(players_), Heard{});
    drops_.assign(static_cast<std::size_t>(players_) * static_cast<std::size_t>(players_), -1);
}

void DropAgreement::heard(PlayerId voter, const AgreementReport& r) {
    if (voter >= heard_.size() || voter == local_) return;
    heard_[voter] = {r, true};
}

void DropAgreement::heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) {
    if (voter >= heard_.size() || slot >= heard_.size() || voter == local_) return;
    drops_[voter * static_cast<std::size_t>(players_) + slot] = epoch;
}

void DropAgreement::forget(PlayerId voter) {
    if (voter >= heard_.size()) return;
    heard_[voter] = Heard{};
    for (int s = 0; s < players_; ++s) drops_[voter * static_cast<std::size_t>(players_) + static_cast<std::size_t>(s)] = -1;
}

// A report that speaks in this instance, from a voter of the view.
bool DropAgreement::current(const Membership& view, PlayerId voter) const {
    if (voter == local_) return view.is_voter(voter);
    return voter < heard_.size() && heard_[voter].has && view.is_voter(voter) && heard_[voter].r.instance == mine_.instance;
}

bool DropAgreement::applied_drop(const Membership& view, PlayerId voter, PlayerId slot) const {
    if (voter == local_ || !view.is_voter(voter) || !view.running(slot)) return false;
    const std::int16_t e = drops_[voter * static_cast<std::size_t>(players_) + slot];
    return e >= 0 && newer_epoch(static_cast<std::uint8_t>(e), view.epoch(slot));
}

// An acceptor takes a slot it says is gone itself, or one it accepted before (that acceptance
// rested on its own vote). Never on another's word: a slot another voter reports accepted is
// carried forward by a proposer (Paxos), but each acceptor takes it only on its own evidence,
// so one voter's reports (a forged promise and acceptance) never drop a player nobody else
// votes gone. (Taking "accepted by a voter other than the proposer" as evidence let one hostile
// voter redirect an honest proposer's ballot to any slot: drop_agreement_fuzz.)
bool DropAgreement::valid(const Membership& view, PlayerId slot) const {
    if (slot >= heard_.size() || !view.running(slot) || view.host_of(slot) != slot) return false;
    if (view.vote_of(local_, slot) == Vote::Gone) return true;
    return mine_.accepted != 0 && mine_.accepted_slot == slot;
}

// Above every ballot in play: promised or accepted anywhere (an acceptor that promised a ballot
// whose proposer fell silent ignores every lower one), or proposed.
std::uint16_t DropAgreement::highest_round(const Membership& view) const {
    std::uint16_t round = std::max({ballot_round(mine_.promised), ballot_round(mine_.accepted), ballot_round(mine_.proposal)});
    for (int v = 0; v < players_; ++v) {
        const auto q = static_cast<PlayerId>(v);
        if (q == local_ || !current(view, q)) continue;
        const AgreementReport& r = heard_[q].r;
        round = std::max({round, ballot_round(r.promised), ballot_round(r.accepted), ballot_round(r.proposal)});
    }
    return round;
}

// Promise the highest ballot proposed (in its voter's own name), accept it if it names a slot.
void DropAgreement::accept_proposals(const Membership& view, std::uint64_t now_us) {
    std::uint16_t best = 0;
    std::uint8_t slot = kNoSlot;
    for (int v = 0; v < players_; ++v) {
        const auto q = static_cast<PlayerId>(v);
        if (!current(view, q)) continue;
        const AgreementReport& r = report_of(q);
        if (r.proposal == 0 || ballot_proposer(r.proposal) != q) continue;
        if (r.proposal > best) {
            best = r.proposal;
            slot = r.proposal_slot;
        }
    }
    if (best == 0 || best < mine_.promised) return;
    if (best != mine_.promised && ballot_proposer(best) != local_) promised_us_ = now_us;
    mine_.promised = best;
    if (slot != kNoSlot && best > mine_.accepted && valid(view, slot)) {
        mine_.accepted = best;
        mine_.accepted_slot = slot;
    }
}

void DropAgreement::propose(const Membership& view, PlayerId wanted, std::uint64_t now_us, std::uint64_t retry_us) {
    const bool mine_current = mine_.proposal != 0 && mine_.promised == mine_.proposal;
    if (mine_.proposal != 0 && mine_.proposal_slot == kNoSlot && mine_current) {
        // Preparing: a majority of the voters promised our ballot, so name the slot.
        int promises = 0;
        std::uint16_t best = 0;
        std::uint8_t carried = kNoSlot;
        for (int v = 0; v < players_; ++v) {
            const auto q = static_cast<PlayerId>(v);
            if (!current(view, q)) continue;
            const AgreementReport& r = report_of(q);
            if (r.promised != mine_.proposal) continue;
            ++promises;
            if (r.accepted != 0 && r.accepted > best && r.accepted_slot < heard_.size()) {
                best = r.accepted;
                carried = r.accepted_slot;
            }
        }
        // A strict majority of the voters, also in a view of two (where the two-player rule,
        // not agreement, drops anyone; a joiner's lapse beside two voters needs both).
        if (promises >= view.running_voters() / 2 + 1) {
            const std::uint8_t slot = carried != kNoSlot ? carried : wanted;
            if (slot != kNoSlot) {
                mine_.proposal_slot = slot;
                accept_proposals(view, now_us);  // our own acceptance, if we may
            }
        }
    }
    if (wanted == kNoSlot) return;
    // A new ballot: none yet, or ours has not ended within retry_us (outbid, or reports lost).
    // Proposers are staggered by slot so that two retrying at once do not outbid each other for ever.
    const std::uint64_t wait = retry_us + retry_us * local_ / static_cast<std::uint64_t>(std::max(players_, 1));
    if (mine_.proposal != 0 && now_us < proposed_us_ + wait) return;
    // Another voter's ballot we promised is in play: let it end first (every voter that wants the
    // slot would otherwise outbid the last one for ever).
    if (mine_.promised != 0 && ballot_proposer(mine_.promised) != local_ && now_us < promised_us_ + wait) return;
    const std::uint16_t round = highest_round(view);
    if (round >= kMaxBallotRound) return;
    const std::uint16_t ballot = make_ballot(static_cast<std::uint16_t>(round + 1), local_);
    if (ballot <= mine_.promised) return;
    mine_.proposal = ballot;
    mine_.proposal_slot = kNoSlot;
    mine_.promised = ballot;
    proposed_us_ = now_us;
}

// The most voters that back slot under one ballot: those that applied its drop back it under
// any ballot, the others under the ballot they accepted it under.
int DropAgreement::backing(const Membership& view, PlayerId slot) const {
    if (slot >= heard_.size()) return 0;
    const auto accepted_under = [&](PlayerId q) -> std::uint16_t {
        if (!current(view, q)) return 0;
        const AgreementReport& r = report_of(q);
        return r.accepted_slot == slot ? r.accepted : 0;
    };
    int applied = 0;
    for (int v = 0; v < players_; ++v) applied += applied_drop(view, static_cast<PlayerId>(v), slot) ? 1 : 0;
    int most = 0;
    for (int v = 0; v < players_; ++v) {
        const std::uint16_t b = accepted_under(static_cast<PlayerId>(v));
        if (b == 0) continue;
        int n = 0;
        for (int w = 0; w < players_; ++w) {
            const auto q = static_cast<PlayerId>(w);
            if (accepted_under(q) == b && !applied_drop(view, q, slot)) ++n;
        }
        most = std::max(most, n);
    }
    return applied + most;
}

std::optional<PlayerId> DropAgreement::step(const Membership& view, PlayerId wanted, std::uint64_t now_us, std::uint64_t retry_us) {
    const std::uint32_t id = view.view_id();
    if (id != mine_.instance) {
        // Another view: a new instance, nothing promised in it yet.
        mine_ = AgreementReport{};
        mine_.instance = id;
        proposed_us_ = promised_us_ = 0;
    }
    if (view.is_voter(local_)) {
        accept_proposals(view, now_us);
        propose(view, wanted, now_us, retry_us);
    }
    // Learn: a slot a majority of its decision's electorate backs is chosen.
    for (int s = 0; s < players_; ++s) {
        const auto x = static_cast<PlayerId>(s);
        if (!view.running(x) || view.host_of(x) != x) continue;
        const int n = view.electorate(x);
        if (n < 3) continue;  // a view of two: the two-player rule, not agreement
        if (backing(view, x) >= view.majority_of(n)) return x;
    }
    return std::nullopt;
}

}  // namespace lockroll::rollback
