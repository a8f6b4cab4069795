// A joiner's reach (issue 21, "a process that cannot reach a majority of the view stops
// confirming frames and reports Partitioned"): whether a joiner that has not loaded its snapshot
// yet -- a process started with `join`, or one dropped and started again as a joiner
// (rollback/rejoin.h) -- is cut off from a majority of the view. A player learns that from its
// own silence votes (Membership::partitioned); a joiner casts none (it is no member until its
// handoff, and confirms nothing), so before this it reported nothing and waited, silent, until
// its runner's connect timeout (30 s and more).
//
// Contract
//  - Whose reach is judged (judges()): a joiner's; and a player's that a running slot told it is
//    a restarted process (told_restarted(): its hello answered `retry` or `disconnected`,
//    Handshake::WelcomeVerdict::restarted) -- a process relaunched with its usual settings (role
//    Player, no `join`) that reaches a minority is refused by them but never kicked (one vote of
//    too few), so before it too said nothing until its runner's connect timeout. One that hears
//    nobody at all is not judged: it cannot tell a restart from a first start nobody answers yet
//    (and at a first start every player waits for every other: the match never ran), so its
//    runner's connect_timeout is what it knows. The session calls begin() and heard() from its
//    first poll for both roles, so a restarted player's silence counts from its start.
//  - The view: the latest offer's slot table (saw_view), else the match's starting one (every
//    slot but the config's absent ones); the joiner's own slot counts as running (after its
//    handoff it does) and so does every peer heard from (a provider cannot shrink the view, as
//    for the vetting, rollback/snapshot_fetch.cpp). Its voters are its running processes
//    (slot_hosts: one per process), and the joiner needs Membership::majority_size() of the
//    *other* ones: its own word vouches for nothing (the vetting, rollback/snapshot_vetting.h,
//    asks the same number for the snapshot's checksum; a view of two: the two-player rule).
//  - A voter is unreached when it has not been heard at all (any datagram: a welcome, a
//    refusal, an offer, a reply) for disconnect_us since begin() -- the silence after which a
//    player votes a slot gone -- or when a vetting ended at its deadline without its answer
//    (named_silent: the joiner asked it and it did not answer), until it is heard again.
//  - A datagram is a claim: ids are not authenticated, so a forger could make an unreached voter
//    look reached. At worst that hides a partition from the report; it never makes the joiner
//    load (the vetting counts each voter's checksum, and still rejects a minority).
//  - judge(): cut_off when some voter is unreached and the others fall short of the majority.
//    `reached`, `others`, `needed` and `unreached` are for the event's detail. Nothing before
//    begin(); disconnect_us = 0 (never time out): only named silence counts.
//  - Left: a voter that welcomed the joiner and is cut off afterwards, before any vetting asks
//    it anything, is not noticed until a vetting does (a joiner stops saying hello once
//    welcomed, and nobody sends a joiner anything else before its snapshot).
//  - Pure value type: no clock (now_us comes in), no I/O. SessionImpl keeps one per session (a
//    rejoin starts a fresh session, and a fresh one) and tells MembershipChanges::
//    joiner_cut_off, which emits the one Partitioned event of the session.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rollback/protocol.h"
#include "rollback/session.h"

namespace lockroll::rollback {

class JoinerReach {
public:
    void begin(std::uint64_t now_us);
    bool begun() const { return begun_; }
    // A running slot answered this player's hello retry or disconnected: it restarted.
    void told_restarted() { restarted_ = true; }
    // Whether a session of `role` that has not run yet is judged (see the contract).
    bool judges(Role role) const { return role == Role::Joiner || (role == Role::Player && restarted_); }
    // Any datagram from slot p: it is reached (named silence withdrawn).
    void heard(PlayerId p, std::uint64_t now_us);
    // A vetting ended at its deadline without these voters' answers.
    void named_silent(std::span<const PlayerId> voters);
    // An offer's slot table: the view as its provider gives it.
    void saw_view(std::span<const SlotEntry> slots) { table_.assign(slots.begin(), slots.end()); }

    struct Verdict {
        bool cut_off = false;
        int reached = 0;  // other voters reached
        int others = 0;   // other voters in the view
        int needed = 0;   // of them, for a majority
        std::vector<PlayerId> unreached;
    };
    Verdict judge(const SessionConfig& c, std::uint64_t now_us) const;

private:
    struct Peer {
        bool heard = false;
        bool named_silent = false;
    };
    bool begun_ = false;
    bool restarted_ = false;
    std::uint64_t begun_us_ = 0;
    std::vector<Peer> peers_;  // per slot, grown as needed
    std::vector<SlotEntry> table_;
};

}  // namespace lockroll::rollback
