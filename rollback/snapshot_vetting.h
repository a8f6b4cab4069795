// A newcomer's check of a snapshot against the match (issue 21, "a joiner trusts any snapshot"):
// the snapshot's hash proves only that the bytes arrived as their sender packed them, so the
// newcomer loads it only if the checksum of its state equals the confirmed checksum that a
// strict majority of the view's running processes report for that frame. No single peer can
// forge one, and none is loaded on a minority's word.
//
// Contract
//  - The view is a Membership (rollback/membership.h) whose local() is this process; the caller
//    builds it (SnapshotFetch: the offer's table, plus every peer that welcomed us). Its running
//    processes (Membership::running_voters(); this one counts only if its own slot runs) are the
//    denominator; the voters asked are those other than this one, the provider included (its
//    reply counts like any other's).
//  - needed(): a strict majority, running / 2 + 1. Only a view of two in which this process's
//    slot runs has no majority of distinct others (its one other voter is the provider): there
//    the configured two-player rule decides, as for drops (Membership::majority_size):
//    PlayOnAlone lets the provider's word decide, NoDrop does not (such a snapshot is never
//    loaded), and detail() names the rule either way.
//  - Each voter's first definite answer counts; "not available" (it has not confirmed that
//    frame yet, or no longer holds it) is no answer, and it is asked again. Answers from
//    non-voters, for another frame, or once decided, change nothing.
//  - Accepted once agreeing answers reach needed(); Rejected once disagreeing ones (or too few
//    voters) make that impossible, or when deadline_us passes without it: silence never counts
//    as agreement, so the provider alone with the others silent is rejected, and detail() names
//    the voters that did not answer (this process is cut off from a majority of the view). The
//    caller asks again (a newer frame, or another provider).
//  - Except for a spectator (AtDeadline::AcceptUncontested): it is no member of the view, its
//    state decides nothing for the others, and between processes it reaches only its host (the
//    one address it is given), whose relayed streams it trusts anyway. Before the deadline it is
//    vetted like a joiner (a majority accepts, any majority against rejects); past it, agreeing
//    answers with none differing accept, and detail() says the others were silent.
//  - Pure bookkeeping: time comes in, nothing is sent from here (due() says whom to ask).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rollback/membership.h"
#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

class SnapshotVetting {
public:
    enum class Verdict : std::uint8_t { Pending, Accepted, Rejected };
    // What the deadline does without a majority: a joiner rejects; a spectator accepts answers
    // that agree with none differing.
    enum class AtDeadline : std::uint8_t { Reject, AcceptUncontested };

    void start(std::uint32_t frame, std::uint64_t checksum, PlayerId provider, const Membership& view,
               std::uint64_t now_us, std::uint64_t deadline_us, AtDeadline at_deadline = AtDeadline::Reject);
    void reset() { active_ = false; }
    bool active() const { return active_; }
    std::uint32_t frame() const { return frame_; }
    PlayerId provider() const { return provider_; }

    void on_reply(PlayerId peer, std::uint32_t frame, bool available, std::uint64_t value);
    // Voters without an answer whose last ask is resend_us old (or never asked): ask them now.
    void due(std::uint64_t now_us, std::uint64_t resend_us, std::vector<PlayerId>& out);
    Verdict verdict(std::uint64_t now_us) const;
    int needed() const { return needed_; }
    // What decided (or is missing), for the event's detail.
    std::string detail(std::uint64_t now_us) const;
    // Past the deadline without a majority (and not accepted uncontested): the voters that had
    // not answered, whom detail() names as cut off (a joiner's reach, rollback/joiner_reach.h).
    std::vector<PlayerId> silent(std::uint64_t now_us) const;

private:
    struct Voter {
        PlayerId peer = 0;
        bool answered = false;
        bool agrees = false;
        std::uint64_t value = 0;
        std::uint64_t asked_us = 0;
        bool asked = false;
    };
    int agreeing() const;
    int disagreeing() const;
    bool impossible() const;
    bool uncontested() const;  // a spectator past its deadline: agreeing answers, none differing
    bool cut_off(std::uint64_t now_us) const;  // past the deadline short of a majority for want of answers

    bool active_ = false;
    std::uint32_t frame_ = 0;
    std::uint64_t checksum_ = 0;
    PlayerId provider_ = 0;
    std::uint64_t deadline_us_ = 0;
    int running_ = 0;  // the view's running processes: the denominator
    int needed_ = 1;
    bool two_player_ = false;  // a view of two with this process in it: the rule decided needed_
    TwoPlayerRule rule_ = TwoPlayerRule::PlayOnAlone;
    AtDeadline at_deadline_ = AtDeadline::Reject;
    std::vector<Voter> voters_;
};

}  // namespace lockroll::rollback
