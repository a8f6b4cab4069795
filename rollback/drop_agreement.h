// DropAgreement: a drop is agreed before anyone applies it (issue 21, "membership that cannot
// split"). Votes (Membership) say who wants a slot gone; they are gossip, and a voter may want
// several slots gone at once or take its word back. Counted as decisions, such votes split the
// view: after a machine stall longer than disconnect_us every process votes every other gone,
// and each one, on hearing one other first, saw a majority for a different drop (3 players: 0
// dropped 2 on 1's standing vote while 1 and 2 dropped 0 on each other's; the two sides then
// confirmed different frames). So the votes only propose; the drop itself is chosen by one round
// of single-decree Paxos per change of the view, carried on the slot tables the peers exchange
// anyway, and a process applies a drop only once a majority of the view's voters has accepted
// that very drop.
//
// The instance is the view itself (Membership::view_id: a hash of every slot's state and
// epoch), so processes that hold the same view are in the same instance whatever way they came
// to it (from frame 0, a snapshot, a rejoin), and any change of the view starts a new one. A
// process that missed a drop learns it from the voters that applied it (below). In each instance:
//  - A proposer is a voter whose votes say slot x is gone (Membership::decided_gone, its own vote
//    included: `wanted`). Unless it promised another voter's ballot within retry_us (that one
//    goes first), it takes a ballot (round << 6 | its slot) above every ballot it has seen and
//    asks for promises (its proposal with no slot yet).
//  - An acceptor promises the highest ballot it sees proposed, by the voter whose slot the ballot
//    names (a ballot in another's name is ignored), and so refuses every lower one.
//  - Once a majority of the voters promised its ballot, the proposer names the slot: the one
//    accepted under the highest ballot among those promises, or else `wanted` (Paxos: a slot a
//    majority may already have chosen is carried forward, never replaced).
//  - An acceptor accepts the proposal it promised if the slot is one it says is gone itself or
//    one it accepted before: never on another voter's word, so one voter's reports drop nobody.
//    (A slot carried forward that no acceptor still votes gone ends nothing: the instance waits,
//    and a drop wanted later in the same view waits with it, until the votes or the view change.)
//  - A slot is chosen when a strict majority of the decision's electorate (Membership::
//    electorate) reports it accepted under one ballot. Every process learns it so, or from the
//    tables of the voters that already applied it (a drop they state, not a vote: SlotEntry::
//    voted clear); a voter counts once.
// What a hostile voter can still do (it speaks only in its own name, on its own connection, but
// may tell each peer something else): cast its own vote, promise and accept anything, and so
// stall agreement (as any voter that stops answering would). It cannot have a slot dropped that
// no honest voter votes gone. But its one vote and acceptance count like any voter's: where it
// and one honest voter make a majority (a view of three), two honest processes that vote each
// other gone (a cut between them) each gather a majority with it if it promises and accepts
// each one's ballot alone (drop_agreement_fuzz: findings/drop_agreement/hostile_splits_by_lying),
// and in larger views, when two slots each have honest voters voting them gone, its forged
// acceptance under a high ballot can make an honest proposer carry the other slot forward.
// Agreement that survives a lying voter needs Byzantine quorums (3f + 1 processes and more
// rounds), which this does not claim; without a liar, one view drops one slot.
//
// Two majorities of one view share a voter, and a voter accepts one slot per ballot and promises
// never to go back below a ballot, so one instance chooses at most one slot at every process.
// A view of two has no majority and is not agreed here: the two-player rule lets each side
// decide for itself (Membership::decided_gone; MembershipChanges::settle_membership).
//
// (A count of agreed drops as the instance, tried first, left a rejoined process at 0 while the
// others stood at 6: its reports never counted, and the 8-player churn soak stalled for good on
// the next kill.)
//
// A pure value type: no clock (now_us is passed in), no I/O. Reports arrive on their voter's own
// connection (the caller's job); a report from a process that is not a voter is ignored.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "rollback/membership.h"
#include "rollback/protocol.h"

namespace lockroll::rollback {

// Ballots: round << 6 | proposer slot; 0 is none. 64 slots at most (kMaxSlotEntries).
inline constexpr int kBallotProposerBits = 6;
inline constexpr std::uint16_t kMaxBallotRound = 0xFFFF >> kBallotProposerBits;
inline std::uint16_t make_ballot(std::uint16_t round, PlayerId proposer) {
    return static_cast<std::uint16_t>(round << kBallotProposerBits | (proposer & ((1u << kBallotProposerBits) - 1)));
}
inline PlayerId ballot_proposer(std::uint16_t b) { return static_cast<PlayerId>(b & ((1u << kBallotProposerBits) - 1)); }
inline std::uint16_t ballot_round(std::uint16_t b) { return static_cast<std::uint16_t>(b >> kBallotProposerBits); }

class DropAgreement {
public:
    DropAgreement(int players, PlayerId local);

    // What this process tells the voters (AgreementReport: rollback/protocol.h).
    const AgreementReport& report() const { return mine_; }
    std::uint32_t instance() const { return mine_.instance; }
    // Some ballot is in play here (a proposal, a promise or an acceptance): the report must
    // travel to every voter.
    bool active() const { return mine_.promised != 0 || mine_.accepted != 0 || mine_.proposal != 0; }

    // voter's report, arrived on its own connection.
    void heard(PlayerId voter, const AgreementReport& r);
    // voter's table says it applied the drop of `slot` into `epoch` (not a vote: SlotEntry::voted
    // clear), or it refused this process as dropped: its word that the slot was chosen.
    void heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch);
    // A new process plays `voter`'s slot (or it left): what its predecessor said is void.
    void forget(PlayerId voter);

    // One step of every role, in the instance of `view` (a new view: a new instance). wanted: the running slot (not this process's) that this voter's
    // votes say is gone, or kNoSlot. A proposal that has not ended in retry_us is made again
    // under a higher ballot (a competing proposer or lost reports). Returns the chosen slot, if
    // any; the caller applies it (the view changes: the next step starts the next instance).
    std::optional<PlayerId> step(const Membership& view, PlayerId wanted, std::uint64_t now_us, std::uint64_t retry_us);

    // Voters that back `slot` in this instance: accepted under the ballot most accept it by, or
    // applied its drop (each once).
    int backing(const Membership& view, PlayerId slot) const;

private:
    struct Heard {
        AgreementReport r;
        bool has = false;
    };
    bool current(const Membership& view, PlayerId voter) const;
    // This process's own report, or the last one heard from voter q (q < heard_.size()).
    const AgreementReport& report_of(PlayerId q) const { return q == local_ ? mine_ : heard_[q].r; }
    bool valid(const Membership& view, PlayerId slot) const;
    void accept_proposals(const Membership& view, std::uint64_t now_us);
    void propose(const Membership& view, PlayerId wanted, std::uint64_t now_us, std::uint64_t retry_us);
    std::uint16_t highest_round(const Membership& view) const;
    bool applied_drop(const Membership& view, PlayerId voter, PlayerId slot) const;

    int players_;
    PlayerId local_;
    AgreementReport mine_;
    std::uint64_t proposed_us_ = 0;  // when our proposal was made
    std::uint64_t promised_us_ = 0;  // when we last promised another voter's ballot
    std::vector<Heard> heard_;                // per voter
    std::vector<std::int16_t> drops_;         // [voter * players + slot]: epoch it dropped slot into, or -1
};

}  // namespace lockroll::rollback
