// Checksum arbitration: for one frame, which reported checksum is right and who holds a wrong
// one. One rule for both sides of issue 21's "one session core": a desynced P2P session picks
// whom it reloads from with it (rollback/recovery_source.h), and the relay server's room decides
// its checksum rounds with it (server/relay_room.h), so the two cannot drift apart.
//
// Contract
//  - Input: one frame's ballot, values[v] the checksum voter v reported for every bit v set in
//    `voted` (voters are slots, at most 64; bits at or past values.size() are ignored). Values
//    are compared whole: a caller that only has the low 32 bits of some (a P2P input message)
//    masks all of them first.
//  - The biggest group of equal values wins; its voters are `winners`, every other voter is in
//    `minority` (the ones that reload, or are told to). A strict majority (more than half the
//    voters) is flagged, since only that can show a voter wrong round after round (the relay's
//    liar kick needs it).
//  - Groups of equal size (no strict majority, or two voters that disagree): ArbitrationRule::tie
//    keeps the group whose lowest voter is the lowest (LowestSlot) or the highest (HighestSlot);
//    `tie_broken` says the tie rule, not the count, decided.
//  - Two voters alone (view_size == 2: nobody else could vote) who disagree, under
//    two_alone_no_majority: neither can be shown wrong, so nobody wins: `no_majority`, both are
//    in `minority`, `winners` is empty (the relay's TwoPlayerDesync::EndMatch).
//  - No voters: an empty verdict (no winners, no minority).
// Pure and allocation-free: no session, no clock, no sim/ types; the server links it (through
// lockroll_relay_protocol) without the rest of rollback/.
#pragma once

#include <cstdint>
#include <span>

namespace lockroll::rollback {

// Equal groups with no majority between them: whose state is kept.
enum class ArbitrationTie : std::uint8_t { LowestSlot, HighestSlot };

struct ArbitrationRule {
    ArbitrationTie tie = ArbitrationTie::LowestSlot;
    // Two voters in a view of two who disagree: nobody wins (else `tie` keeps one of them).
    bool two_alone_no_majority = false;
};

struct ArbitrationVerdict {
    int voters = 0;
    std::uint64_t value = 0;     // the winning value (0 when there is no winner)
    std::uint64_t winners = 0;   // bit v: voter v reported `value`
    std::uint64_t minority = 0;  // bit v: voter v reported something else (no_majority: every voter)
    bool strict_majority = false;  // more than half the voters are winners
    bool tie_broken = false;       // another group was as big: ArbitrationRule::tie chose
    bool no_majority = false;      // two voters alone disagree under two_alone_no_majority

    // The lowest winning voter (the one to reload from), or -1 when nobody won.
    int lowest_winner() const;
    bool is_winner(int voter) const { return voter >= 0 && voter < 64 && ((winners >> voter) & 1u) != 0; }
    bool is_minority(int voter) const { return voter >= 0 && voter < 64 && ((minority >> voter) & 1u) != 0; }
};

// values[v] for every bit v of `voted`; view_size: the voters there could be (running voters),
// which only the two-alone rule reads.
ArbitrationVerdict arbitrate(std::span<const std::uint64_t> values, std::uint64_t voted, int view_size,
                             const ArbitrationRule& rule);

}  // namespace lockroll::rollback
