// The membership fuzzer's input format, shared by the target (fuzz/membership_fuzz.cpp) and the
// seed writer (fuzz/seeds.cpp). A header of four bytes, then operations of four bytes each:
//
//   header  [players] [local | rule] [hosts lo] [hosts hi]
//     players  1 + players % kMaxFuzzPlayers
//     local    (byte & 0x7f) % players; bit 7 set: TwoPlayerRule::NoDrop, else PlayOnAlone
//     hosts    a 16-bit mask; 0: one process per slot (no hosts table). Else bit s (s >= 1) makes
//              slot s a guest of the nearest self-hosted slot below it (the local slot always
//              hosts itself, as the session's config requires); bit 0 set passes a table one
//              entry too long, which Membership must treat as "one process per slot"
//   op      [op] [a] [b] [c], kind = op % kOpCount, vote = (op / kOpCount) % 3: rollback::Vote's
//           value (None, Runs, Gone)
//     kVote       voter id(a) says `vote` about slot id(b) at the slot's epoch + c - 128 (mod 256)
//     kVoteRaw    the same at epoch c, whatever the slot's epoch
//     kVoteLocal  the local process says slot id(b) is gone (a odd) or runs (a even)
//     kSettle     the session's tick: drop every slot the votes decide, and its guests
//     kSet        a change no vote decides: slot b % players becomes state a % 3 (Absent,
//                 Running, Disconnected) in the epoch 1 + c % 127 ahead of its own; a & 0x80:
//                 instead a join handed over (Running in that epoch, its process joining: no
//                 voter until it plays); else a & 0x40: instead the slot's joiner starts playing
//                 (its stream started; the view does not change)
//     kChorus     every voter in the mask a | c << 8 says `vote` about slot id(b) (Gone: at the
//                 epoch it would leave into; Runs and None: at its epoch)
//     kLocalAll   the local process says every slot in the mask b | c << 8 is gone (a odd) or
//                 runs (a even): a silence or a heal
//   id(x)   x < 0xF0: x % (players + 2), so slots players and players + 1 are out of range; else
//           0xFFFFFFF0 + (x & 15), far out of range
// A trailing partial operation is ignored, and so is everything after kMaxOps operations.
#pragma once

#include <cstdint>
#include <vector>

#include "rollback/membership.h"

namespace lockroll::fuzz {

inline constexpr int kMaxFuzzPlayers = 10;
inline constexpr int kMaxOps = 64;

// The kind of an operation, numbered from 0 in this order (the corpus's bytes depend on it: a new
// kind goes last, before kOpCount).
enum MembershipOp : std::uint8_t { kVote, kVoteRaw, kVoteLocal, kSettle, kSet, kChorus, kLocalAll, kOpCount };

inline std::vector<std::uint8_t> membership_header(int players, int local, bool no_drop, std::uint16_t hosts = 0) {
    return {static_cast<std::uint8_t>(players - 1), static_cast<std::uint8_t>(local | (no_drop ? 0x80 : 0)),
            static_cast<std::uint8_t>(hosts), static_cast<std::uint8_t>(hosts >> 8)};
}

// The vote travels as Membership's own Vote value (the target casts it back), so the script
// cannot name a vote Membership does not have.
inline void membership_op(std::vector<std::uint8_t>& script, MembershipOp op, rollback::Vote vote, std::uint8_t a,
                          std::uint8_t b, std::uint8_t c) {
    script.insert(script.end(),
                  {static_cast<std::uint8_t>(int{op} + int{kOpCount} * static_cast<int>(vote)), a, b, c});
}

}  // namespace lockroll::fuzz
