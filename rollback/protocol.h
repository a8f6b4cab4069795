// Message encode/decode: what travels between sessions, one message per datagram.
// The byte-by-byte layout is docs/wire-format.md; this header is its code.
//
// Contract
//  - Every field is written on its own, little-endian (rollback/bytes.h). No struct is copied
//    onto the wire.
//  - Decoding trusts nothing: every count and length is checked against the bytes actually
//    present and against fixed limits before anything is allocated or read, trailing bytes are
//    an error, and a failure is a returned message, never an assert or an exception. The
//    session counts failures per peer and stops listening to a peer after too many.
//  - Frames travel as their low 16 bits; the receiver unwraps them against a frame it knows is
//    close (peers are never 32768 frames apart), which keeps the per-frame input message small.
//  - Inputs are sent unreliably and redundantly: every input message carries all of the
//    sender's inputs from the receiver's last ack on, run-length coded (inputs repeat a lot).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rollback/session_types.h"

namespace lockroll::rollback {

inline constexpr std::size_t kMaxDatagramBytes = 1200;  // fits any path MTU with UDP/IP headers
inline constexpr std::size_t kMaxInputSize = 64;
inline constexpr std::uint16_t kMaxQueryItems = 128;
inline constexpr int kMaxFields = 16;

// Bumped whenever a message's bytes change meaning; hellos carry it and a mismatch is refused.
inline constexpr std::uint16_t kProtocolVersion = 3;

// Input, Query and Reply are this header's; the rest are control_messages.h's.
enum class MessageKind : std::uint8_t {
    Input = 1,
    Query = 2,
    Reply = 3,
    Hello = 4,
    Welcome = 5,
    SnapshotRequest = 6,
    SnapshotOffer = 7,
    SnapshotChunk = 8,
};
inline constexpr std::uint8_t kLastMessageKind = 8;

// Kind byte of an input message: low 4 bits the kind, bit 4 "time sync present", bits 5-6 the
// number of checksums carried (0..3), bit 7 "extension present" (slot table and relayed streams,
// only while some slot is not simply running: a steady match pays nothing for it).
inline constexpr std::uint8_t kKindMask = 0x0F;
inline constexpr std::uint8_t kFlagTimeSync = 0x10;
inline constexpr int kChecksumCountShift = 5;
inline constexpr std::uint8_t kChecksumCountMask = 0x60;
inline constexpr std::uint8_t kFlagExtension = 0x80;
// Extension: bit 7 of the slot-entry count byte says an agreement report follows the table
// (version 3); bit 7 of a slot entry's state byte marks the sender's vote (SlotEntry::voted).
inline constexpr std::uint8_t kFlagAgreement = 0x80;
inline constexpr std::uint8_t kFlagVoted = 0x80;
inline constexpr int kMaxChecksumsPerMessage = 3;
inline constexpr int kMaxSlotEntries = 64;
inline constexpr int kMaxStreamBlocks = 16;

// SlotState (a slot's lifecycle state as peers gossip it): rollback/session_types.h.
inline constexpr std::uint8_t kLastSlotState = 2;

// One slot as the sender sees it, and how many of that slot's inputs the sender holds
// (its confirmed count, low 16 bits): what relays and the disconnect agreement are built on.
struct SlotEntry {
    std::uint8_t slot = 0;
    SlotState state = SlotState::Running;
    std::uint8_t epoch = 0;
    std::uint16_t count = 0;
    // The sender's vote that the slot is gone (state Disconnected in the epoch it would leave
    // into), not a drop it applied: only agreed drops are applied (rollback/drop_agreement.h).
    // On the wire: bit 7 of the state byte.
    bool voted = false;
};

inline constexpr std::uint8_t kNoSlot = 0xFF;

// The sender's side of the agreement on the next drop (rollback/drop_agreement.h): the
// instance (its view: Membership::view_id), the highest ballot it promised, the ballot and slot
// it accepted, and its own proposal (ballot; slot kNoSlot while it still gathers promises).
// Ballots: round << 6 | proposer slot, 0 none.
struct AgreementReport {
    std::uint32_t instance = 0;
    std::uint16_t promised = 0;
    std::uint16_t accepted = 0;
    std::uint8_t accepted_slot = kNoSlot;
    std::uint16_t proposal = 0;
    std::uint8_t proposal_slot = kNoSlot;
    bool operator==(const AgreementReport&) const = default;
};
inline constexpr std::size_t kAgreementBytes = 12;

// Consecutive inputs of one slot's stream, forwarded by a peer that is not that slot's player
// (the owner writing an absent slot's neutral inputs, or anyone filling a gap another peer has).
struct StreamBlock {
    std::uint8_t slot = 0;
    bool absent = false;            // every input in the block is the flagged neutral input
    std::uint16_t first_frame = 0;
    std::uint8_t frame_count = 0;
    std::vector<std::uint8_t> inputs;  // frame_count * input_size bytes
};

struct InputMessage {
    std::uint16_t ack = 0;           // next frame of the receiver's inputs the sender needs
    std::uint16_t first_frame = 0;   // frame of the first input carried
    std::uint8_t frame_count = 0;    // inputs carried (0: just an ack)
    std::vector<std::uint8_t> inputs;  // frame_count * input_size bytes
    bool has_time_sync = false;
    std::uint16_t sender_frame = 0;  // the sender's displayed frame
    std::int8_t advantage = 0;       // sender's estimate of (receiver frame - sender frame)
    // Checksums of confirmed frames of the sender, oldest first. Only the low 32 bits travel
    // (decoded values are zero-extended): a desync persists, so a 2^-32 chance of one frame's
    // collision only delays the alert to the next checkpoint, and the 4 bytes saved per tick are
    // a quarter of a steady-state message. Narrowing queries carry full 64-bit values.
    std::uint8_t checksum_count = 0;
    std::uint16_t checksum_frames[kMaxChecksumsPerMessage] = {};
    std::uint64_t checksums[kMaxChecksumsPerMessage] = {};
    // Round-trip measurement, with the time-sync fields: the sender's clock (units of 100 µs,
    // wrapping), the last stamp it received from the receiver, and how long it held that stamp
    // before this send (100 µs units). RTT = now - echo - hold, free of any tick-rate ack delay.
    std::uint16_t stamp = 0;
    std::uint16_t echo = 0;
    std::uint16_t hold = 0;
    // Extension (kFlagExtension): the sender's slot table with its counts, and relayed streams.
    bool has_extension = false;
    std::vector<SlotEntry> slots;
    std::vector<StreamBlock> blocks;
    // Extension only: the sender's agreement report (bit 7 of the slot-entry count).
    bool has_agreement = false;
    AgreementReport agreement;
};

enum class QueryWhat : std::uint8_t {
    FrameChecksums = 1,  // confirmed checksums of frames [frame, frame + count)
    BodyHashes = 2,      // body hashes of bodies [start, start + count) at frame
    BodyFields = 3,      // every field of body `start` at frame (count 1)
};

struct QueryMessage {
    QueryWhat what = QueryWhat::FrameChecksums;
    std::uint32_t frame = 0;
    std::uint32_t start = 0;
    std::uint16_t count = 0;
};

struct ReplyMessage {
    QueryWhat what = QueryWhat::FrameChecksums;
    bool available = false;  // false: the sender no longer (or not yet) holds that evidence
    std::uint32_t frame = 0;
    std::uint32_t start = 0;
    std::uint16_t count = 0;
    std::vector<std::uint64_t> values;  // FrameChecksums, BodyHashes: count values
    std::vector<std::int64_t> fields;   // BodyFields: the body's fields
};

// Most inputs an input message may carry so that even incompressible inputs fit a datagram.
std::uint8_t max_frames_per_message(std::size_t input_size);
// Bytes an input message without extension may take at most; extension bytes must fit in what
// is left of kMaxDatagramBytes (the session shrinks blocks to fit).
std::size_t max_base_input_message_bytes(std::size_t input_size);
// Encoded size of a stream block with these inputs (run-length coded).
std::size_t encoded_block_bytes(const StreamBlock& b, std::size_t input_size);

// The kind of a datagram, or nullopt when the first byte names none (or the datagram is empty).
std::optional<MessageKind> peek_kind(std::span<const std::uint8_t> datagram);

// Append the encoding to out. Preconditions (programming errors, checked, std::invalid_argument):
// inputs.size() == frame_count * input_size, frame_count <= max_frames_per_message(input_size),
// value/field counts within the limits above.
void encode(const InputMessage& m, std::size_t input_size, std::vector<std::uint8_t>& out);
void encode(const QueryMessage& m, std::vector<std::uint8_t>& out);
void encode(const ReplyMessage& m, std::vector<std::uint8_t>& out);

// nullptr on success; otherwise a static description of what was wrong (m is then unspecified).
// `m` is reused across calls so that steady-state decoding does not allocate.
const char* decode(std::span<const std::uint8_t> datagram, std::size_t input_size, InputMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, QueryMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, ReplyMessage& m);

// The 32-bit frame whose low 16 bits are `low` and that is closest to `reference`; nullopt when
// that frame would be negative (cannot be meant).
std::optional<std::uint32_t> unwrap_frame(std::uint16_t low, std::uint32_t reference);

}  // namespace lockroll::rollback
