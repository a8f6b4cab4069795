// Whom a desynced P2P session reloads from (issue 21's desync recovery): the slots are grouped by
// their confirmed checksum of the first frame that differs; the biggest group is right, and a
// tie between groups (always so with two players) keeps the group of the lowest slot (or the
// highest, DesyncKeep::HighestSlot). Only the low 32 bits of a checksum are compared.
//
// Contract
//  - recovery_source(): nullopt when `me` is in the group kept (the others reload); else the
//    lowest slot of that group, whose state `me` reloads. Pure: no session, no time. The rule
//    itself is rollback/arbitration.h's, the one the relay server's rooms decide with.
//  - choose_recovery(): the same, and also which rule kept the group, for the recovery's event
//    (issue 21: with two players no majority exists, and the report must say the tie rule
//    decided): "the biggest group, N of M", or with `tie`, "no majority (a tie, N against N):
//    the tie rule (two_player_keep: lowest_slot) keeps slot S's group".
//  - next_recovery_step(): what a session that saw a mismatch does about it now. It waits while
//    it still narrows the mismatch with a peer (3 s at most from the mismatch) and while a live
//    player has not told its checksum of the frame (5 s at most; one silent longer is left out).
//    Meanwhile the session asks such a player for it (DesyncDetector::ask_checksum): one whose
//    messages were lost while it confirmed that frame would never tell it again by itself, and
//    left out it can turn a majority into a tie (issue 21: a relay's lie confirmed through a
//    one-way cut, tests/rollback/relay_equivocation_test.cpp).
//    It forgets the mismatch when its own checksum of the frame is gone or it is in the group
//    kept; it gives up (fails) when it would reload once more than max_recoveries allows; else
//    it reloads from recovery_source(), the step saying which rule chose it (choose_recovery()).
//    Pure: time comes in as values.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "rollback/session.h"

namespace lockroll::rollback {

// theirs: (slot, its confirmed checksum of that frame) of every peer that answered.
std::optional<PlayerId> recovery_source(PlayerId me, std::uint64_t mine,
                                        std::span<const std::pair<PlayerId, std::uint64_t>> theirs, DesyncKeep keep);

struct RecoveryChoice {
    std::optional<PlayerId> source;  // as recovery_source()
    bool tie = false;                // another group was as big: the tie rule, not a count, chose
    std::string rule;                // which rule kept the group
};
RecoveryChoice choose_recovery(PlayerId me, std::uint64_t mine, std::span<const std::pair<PlayerId, std::uint64_t>> theirs,
                               DesyncKeep keep);

// A desynced session's case as it stands now.
struct RecoveryCase {
    PlayerId me = 0;
    std::optional<std::uint64_t> mine;  // our confirmed checksum of the mismatched frame, while kept
    // Every live player peer and its confirmed checksum of that frame, once it told it.
    std::span<const std::pair<PlayerId, std::optional<std::uint64_t>>> peers;
    bool investigating = false;  // the desync detector still narrows a mismatch with some peer
    std::uint64_t mismatch_since_us = 0;
    std::uint64_t now_us = 0;
    int recoveries = 0;  // reloads so far
    int max_recoveries = 0;
    DesyncKeep keep = DesyncKeep::LowestSlot;
};

struct RecoveryStep {
    enum class Act { Wait, Forget, Reload, GiveUp };
    Act act = Act::Wait;
    PlayerId from = 0;  // Reload: whose state
    bool tie = false;   // Reload: RecoveryChoice's
    std::string rule;   // Reload: which rule kept from's group (RecoveryChoice's)
};

RecoveryStep next_recovery_step(const RecoveryCase& c);

}  // namespace lockroll::rollback
