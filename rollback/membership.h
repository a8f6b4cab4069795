// Who plays: the numbered view of a match (per slot: state and epoch) and every voter's latest
// word about every slot, and the rule that turns those words into a slot leaving (issue 21).
//
// A slot leaves the view only when a strict majority of the view's running players says it is
// gone. Votes are counted per process: a process that plays several slots (SessionConfig::
// slot_hosts) is one voter and counts once in the denominator, and its guest slots leave with
// it. The slot voted on counts in the denominator; the voters are the other running processes,
// the local one included. So, with one process per slot:
//
//   view of   votes needed   e.g.
//   2         1 / none       TwoPlayerRule: PlayOnAlone (default): each side decides for
//                            itself: its own vote drops the other and it plays on alone; the
//                            other's vote never drops its own slot; NoDrop: nobody is dropped
//   3         2              one killed: the two survivors drop it; split 2/1: the two drop the
//                            one, the one drops nobody
//   4         3              one killed: dropped; split 2/2: nobody reaches 3, nobody is dropped
//   8         5              split 5/3: the five drop the three; the three drop nobody
//
// Each voter speaks for itself: the caller must pass a peer's vote only when it arrived on that
// peer's own connection. A peer's slot table is its vote, never a fact about others: a vote
// from a process that is not running in this view, a process's word about itself (or its own
// guests), a word about a guest (it follows its host) and a stale vote (cast about an older
// epoch of the slot) are ignored. A vote stays until its voter changes it ("runs" withdraws it)
// or the view changes for that slot or voter.
//
// A view of two has no majority, so no vote about another counts there: each process decides
// for itself, on its own evidence (silence, a restart claim it checked). The other's word about
// this process's slot is a claim, never a fact: a table still carrying a withdrawn vote, arriving
// just as a third slot's drop left a view of two, kicked a survivor (issue 21). If the other
// really dropped this one, it stops talking to it and this one's own silence rule applies.
//
// A joiner is no voter until it plays (issue 21, "membership that cannot freeze"). A slot handed
// over to a new process (hand_over(): the owner's handoff, or a peer's table saying so) runs in
// the view, but its process votes nothing until it has loaded a snapshot and its own stream has
// started; the caller says when with started(). Until then it is not counted among the voters
// (running_voters(), majority_size()) of any decision but the one about itself: the slot voted on
// counts in that one's denominator as always, so a handoff that lapses needs the same votes it
// did. Counted as a voter, a joiner that cannot vote yet only raised the bar: 3 players, slot 1
// handed over, slot 2 killed before slot 1 played, left the survivor 1 vote of the 2 it needed
// for good (partitioned, stalled), and the joiner, whose snapshot needed a majority of three,
// never loaded. Why this rule and not "a handoff that lapses falls back to absent at each peer":
//  - The voter base is what it was before the handoff (a slot beyond the view was no voter
//    either): a joiner, forged or not, can neither shrink it to hijack a decision nor, as
//    before, grow it to block every drop. Only a majority (the owner's drop of the slot before)
//    or the joiner's own stream starting (it loaded a snapshot a majority vetted) changes it.
//  - A lapse that each peer applied on its own would be a drop without votes: views would split.
//  - Partitions are found as before: partitioned() weighs the voters a peer still hears against
//    a majority of each decision it wants, the joiner's own included.
// "Started" is each peer's own observation (its first real input of the slot), so two peers may
// count a joiner differently for about a one-way trip; two majorities of bases that differ by
// one process always share a voter, except where the two-player rule already lets each side
// of a view of two decide for itself (and say it plays alone).
//
// A pure value type: no clock, no I/O. Joins are not votes: whoever hands a slot over (the
// owner) decides them, and the caller records them with hand_over() (or set()).
#pragma once

#include <cstdint>
#include <vector>

#include "rollback/protocol.h"
#include <lockroll/rollback/session.h>
#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

// TwoPlayerRule (two running players have no strict majority): rollback/session.h.

// Epochs wrap at 256: a is newer than b when it is less than half the circle ahead.
inline bool newer_epoch(std::uint8_t a, std::uint8_t b) {
    return static_cast<std::int8_t>(static_cast<std::uint8_t>(a - b)) > 0;
}

enum class Vote : std::uint8_t { None, Runs, Gone };

// What became of a vote given to Membership::vote.
enum class Tally : std::uint8_t {
    Counted,      // the voter's word changed and now counts
    Repeated,     // the same word as before
    NotAVoter,    // the voter is not a running process of the view (or out of range)
    AboutItself,  // a process's word about its own slot or guests says nothing new
    NotRunning,   // the slot is not running: there is nothing to vote on
    AboutAGuest,  // a guest slot follows its host; only votes about the host count
    Stale,        // "gone" at an epoch not newer than the view's, or "runs" at another epoch
};

class Membership {
public:
    // Every slot running in epoch 0. hosts: empty (one process per slot) or one entry per slot,
    // hosts[s] = the slot whose process plays s (validated by the session's config).
    Membership(int players, PlayerId local, TwoPlayerRule rule, std::vector<PlayerId> hosts = {});

    int players() const { return static_cast<int>(slots_.size()); }
    PlayerId local() const { return local_; }
    TwoPlayerRule rule() const { return rule_; }
    SlotState state(PlayerId s) const { return slots_[s].state; }
    std::uint8_t epoch(PlayerId s) const { return slots_[s].epoch; }
    bool running(PlayerId s) const { return slots_[s].state == SlotState::Running; }
    PlayerId host_of(PlayerId s) const { return hosts_.empty() ? s : hosts_[s]; }
    // Handed over to a process whose own stream has not started here yet (hand_over()).
    bool joining(PlayerId s) const { return s < slots_.size() && slots_[s].joining; }
    // p votes: a running process (a host slot) that is not joining.
    bool is_voter(PlayerId p) const { return voter(p); }
    // Running processes in the view that vote (a joiner only once it plays): the denominator of
    // every decision but one about a joining slot (electorate()).
    int running_voters() const;
    // The processes a decision about running slot s counts: the voters, and s itself when it is
    // joining (the slot voted on always counts in the denominator).
    int electorate(PlayerId s) const { return running_voters() + (joining(s) ? 1 : 0); }
    // The fewest of n processes that are a majority: n / 2 + 1, or 1 when n is 2 under
    // PlayOnAlone (the two-player rule).
    int majority_of(int n) const;
    // majority_of(running_voters()).
    int majority_size() const;

    // The view's identity: a hash (FNV-1a, 32 bits) of every slot's state and epoch. Processes
    // that hold the same view agree on it, however they came to it; every drop, join or restart
    // changes it. The instance of the agreement on the next drop (rollback/drop_agreement.h).
    std::uint32_t view_id() const;
    // A change of the view that no vote decides: the starting table, a snapshot's table, a rejoin
    // handed over by the owner, a process that says it restarted. Forgets the votes about s and
    // the votes s cast (a new process in the slot starts with no word said).
    // Not joining (a table or snapshot says nothing about whether a joiner plays yet).
    void set(PlayerId s, SlotState state, std::uint8_t epoch);
    // A join: s runs in `epoch`, handed to a new process that is no voter until started().
    void hand_over(PlayerId s, std::uint8_t epoch);
    // The joiner of s plays (its own stream started here): it votes and counts from now on.
    void started(PlayerId s);
    // s leaves the view: Disconnected in the next epoch, its votes and those about it forgotten.
    void leave(PlayerId s);

    // voter's word about slot s: Gone with the epoch s would leave into (newer than the view's),
    // or Runs in the view's epoch.
    Tally vote(PlayerId voter, PlayerId s, Vote v, std::uint8_t epoch);
    // The local process's word: gone (the epoch after the view's) or runs (the view's).
    Tally vote_local(PlayerId s, bool gone);
    // voter's word about s as it counts now (None: none, or not counted).
    Vote vote_of(PlayerId voter, PlayerId s) const;
    // Voters that say s is gone, among the running processes.
    int gone_votes(PlayerId s) const;
    // The votes say running slot s leaves: the caller drops it (and its guests) with leave().
    // In a view of two (PlayOnAlone): only the local vote about the other slot says so.
    bool decided_gone(PlayerId s) const;
    // The first running host slot the votes say leaves, or players() if none.
    PlayerId next_gone() const;

    // The entry this process sends about s in its slot table: its vote "gone" (Disconnected in
    // the epoch s would leave into) when it casts one, else the view's state and epoch.
    SlotState advertised_state(PlayerId s) const;
    std::uint8_t advertised_epoch(PlayerId s) const;
    // The local process votes some running slot gone.
    bool votes_any_gone() const;
    // The local process votes some slot gone and the voters it still hears (itself included)
    // are no majority of that decision's electorate: a drop it wants cannot be decided, and it
    // must not drop anyone on its own (issue 21: split matches).
    bool partitioned() const;

private:
    struct Slot {
        SlotState state = SlotState::Running;
        std::uint8_t epoch = 0;
        bool joining = false;
    };
    struct Word {
        Vote vote = Vote::None;
        std::uint8_t epoch = 0;
    };
    bool voter(PlayerId p) const { return p < slots_.size() && running(p) && host_of(p) == p && !slots_[p].joining; }
    bool majority(int votes) const;
    void forget(PlayerId s);
    Word& word(PlayerId voter, PlayerId s) { return words_[voter * slots_.size() + s]; }
    const Word& word(PlayerId voter, PlayerId s) const { return words_[voter * slots_.size() + s]; }

    PlayerId local_;
    TwoPlayerRule rule_;
    std::vector<PlayerId> hosts_;
    std::vector<Slot> slots_;
    std::vector<Word> words_;  // [voter * players + slot]
};

}  // namespace lockroll::rollback
