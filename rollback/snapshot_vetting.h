// A newcomer's check of a snapshot against the match (issue 21, "a joiner trusts any snapshot"):
// the snapshot's hash proves only that the bytes arrived as their sender packed them, so the
// newcomer loads it only if the checksum of its state equals the confirmed checksum that a
// majority of the view's other processes report for that frame. No single peer can forge one.
//
// Contract
//  - voters: the running processes of the view other than this one, the provider included
//    (its reply counts like any other). A majority is voters / 2 + 1 of them. With one voter
//    (two players: no majority exists) its word decides, and detail() says so.
//  - Each voter's first definite answer counts; "not available" (it has not confirmed that
//    frame yet, or no longer holds it) is no answer, and it is asked again. Answers from
//    non-voters, for another frame, or once decided, change nothing.
//  - Accepted once agreeing answers reach a majority; Rejected once disagreeing ones make that
//    impossible. When deadline_us passes undecided: Accepted if some answers agree and none
//    differs (the silent ones may simply not be reachable yet), else Rejected (asked again).
//  - Pure bookkeeping: time comes in, nothing is sent from here (due() says whom to ask).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

class SnapshotVetting {
public:
    enum class Verdict : std::uint8_t { Pending, Accepted, Rejected };

    void start(std::uint32_t frame, std::uint64_t checksum, PlayerId provider, std::vector<PlayerId> voters,
               std::uint64_t now_us, std::uint64_t deadline_us);
    void reset() { active_ = false; }
    bool active() const { return active_; }
    std::uint32_t frame() const { return frame_; }
    PlayerId provider() const { return provider_; }

    void on_reply(PlayerId peer, std::uint32_t frame, bool available, std::uint64_t value);
    // Voters without an answer whose last ask is resend_us old (or never asked): ask them now.
    void due(std::uint64_t now_us, std::uint64_t resend_us, std::vector<PlayerId>& out);
    Verdict verdict(std::uint64_t now_us) const;
    int needed() const { return static_cast<int>(voters_.size()) / 2 + 1; }
    // What decided (or is missing), for the event's detail.
    std::string detail(std::uint64_t now_us) const;

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

    bool active_ = false;
    std::uint32_t frame_ = 0;
    std::uint64_t checksum_ = 0;
    PlayerId provider_ = 0;
    std::uint64_t deadline_us_ = 0;
    std::vector<Voter> voters_;
};

}  // namespace lockroll::rollback
