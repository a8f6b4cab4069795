// The drop-agreement fuzzer's input format, shared by the target (fuzz/drop_agreement_fuzz.cpp)
// and the seed writer (fuzz/seeds.cpp). A header of four bytes, then operations of four bytes:
//
//   header  [players] [hostile] [retry] [unused]
//     players  3 + players % 6 (3..8 processes, one slot each, every one a voter)
//     hostile  bit 7 set: every process is honest; else process hostile % players is hostile
//     retry    the proposers' retry_us is 100 * (1 + retry % 16)
//   op      [op] [a] [b] [c], kind = op % kOpCount, vote = (op / kOpCount) % 3 (None, Runs, Gone)
//     kVote     process a % n says `vote` about slot b % n (gone: at the epoch it would leave
//               into, runs and none: at its epoch), to itself and, as its vote, to the Memberships
//               of the processes in mask c; the hostile one's word goes out at epoch + c - 128 to
//               every honest process instead (any word it likes)
//     kStep     process a % n takes one step (an honest process passes the slot its votes want,
//               as the session does); b odd: then sends its report to every other process
//     kSend     process a % n's report as it stands now goes in flight to every process in mask c
//     kDeliver  the flight b % (in flight) is heard by its receiver; c & 1: it stays in flight
//               (duplicated, heard again later), c & 2: lost instead (dropped unheard)
//     kTime     time passes: (1 + a) * 50 us
//     kTable    process a % n's slot table reaches the processes in mask c: each drop it applied
//               since the start (heard_drop). From the hostile one: it claims to have applied
//               the drop of slot b % n into epoch (receiver's epoch of it) + c - 128, to every
//               honest process
//     kForge    sets a field of the hostile process's forged report (below)
//     kForged   the forged report goes in flight from the hostile process to the processes in
//               mask c (b & 1: its instance is each receiver's current view, else as set)
//   kForge  [op] [field] [lo] [hi]; field % 8:
//     0 instance: lo % 4: the starting view's id, 1 + that id, lo | hi << 8, 0
//     1 promised, 2 accepted, 4 proposal: the ballot lo | hi << 8; field & 8: instead process
//       (lo % n)'s current proposal (lo & 0x80: its promise) plus (int8) hi
//     3 accepted_slot, 5 proposal_slot: lo (any byte: 0xFF is none, a slot past n, ...)
//     6 a ballot to all three ballot fields at once (as field 1), 7 clear the report
// A trailing partial operation is ignored, and so is everything after kAgreeMaxOps operations.
#pragma once

#include <cstdint>
#include <vector>

namespace lockroll::fuzz {

inline constexpr int kAgreeMinPlayers = 3;
inline constexpr int kAgreeMaxPlayers = 8;
inline constexpr int kAgreeMaxOps = 256;
inline constexpr int kAgreeMaxFlights = 64;

// In the order of the format above (op % kAgreeOpCount).
enum AgreementOp : std::uint8_t {
    kAgreeVote,
    kAgreeStep,
    kAgreeSend,
    kAgreeDeliver,
    kAgreeTime,
    kAgreeTable,
    kAgreeForge,
    kAgreeForged,
    kAgreeOpCount,
};

// kForge's field % 8, in the order of the format above.
enum ForgeField : std::uint8_t {
    kForgeInstance,
    kForgePromised,
    kForgeAccepted,
    kForgeAcceptedSlot,
    kForgeProposal,
    kForgeProposalSlot,
    kForgeAllBallots,
    kForgeClear,
    kForgeCopy = 8,  // or'ed into a ballot field: copy a process's proposal (or promise)
};

// The vote field of a kAgreeVote (Membership's Vote, in its order).
enum AgreeVote : std::uint8_t { kAgreeNone = 0, kAgreeRuns = 1, kAgreeGone = 2 };

inline constexpr std::uint8_t kNoHostile = 0x80;

inline std::vector<std::uint8_t> agreement_header(int players, std::uint8_t hostile, int retry = 0) {
    return {static_cast<std::uint8_t>(players - kAgreeMinPlayers), hostile, static_cast<std::uint8_t>(retry), 0};
}

inline void agreement_op(std::vector<std::uint8_t>& script, AgreementOp op, std::uint8_t a, std::uint8_t b,
                         std::uint8_t c, AgreeVote vote = kAgreeNone) {
    script.insert(script.end(), {static_cast<std::uint8_t>(int{op} + int{kAgreeOpCount} * int{vote}), a, b, c});
}

}  // namespace lockroll::fuzz
