// What a running peer hands a joiner, a spectator or a desynced peer: the saved state of one of
// its confirmed frames plus every input it holds from that frame on, as one checksummed blob,
// pulled in chunks (control_messages.h). Byte layout: docs/wire-format.md, "Snapshot transfer".
//
// Contract
//  - pack_transfer writes field by field, little-endian. unpack_transfer trusts nothing: sizes
//    are checked against the bytes present and the caller's limits before anything is
//    allocated, and a failure is a message naming what was wrong, never an exception.
//  - TransferReceiver assembles chunks of one offer. It allocates once (the offer's size, which
//    the caller has checked against its limit), ignores chunks of other offers and repeats, and
//    verifies the whole blob's XXH3-64 before handing it out: a corrupted or truncated transfer
//    is rejected, and the caller asks again.
//  - TransferSender is the providing side both sessions share: the blobs it offered, bounded
//    whatever newcomers ask (one per peer, at most kMaxTransfers, none older than its lifetime
//    once a new one is offered), numbered by next_transfer_id.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/control_messages.h"
#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

struct StreamInputs {
    std::uint32_t count = 0;            // inputs from the snapshot frame on
    std::vector<std::uint8_t> inputs;   // count * input_size
    std::vector<std::uint8_t> absent;   // count flags (0/1)
};

struct TransferContents {
    std::uint32_t frame = 0;
    std::vector<std::uint8_t> state;
    std::vector<StreamInputs> streams;  // one per slot
};

std::vector<std::uint8_t> pack_transfer(const TransferContents& t, std::size_t input_size);
// Empty string on success.
std::string unpack_transfer(std::span<const std::uint8_t> blob, std::size_t state_size, int players,
                            std::size_t input_size, std::uint32_t max_inputs_per_stream, TransferContents& out);

std::uint64_t transfer_hash(std::span<const std::uint8_t> blob);

// Transfer ids are never 0, which in a SnapshotRequestMessage means "please offer": the id after
// `id`, skipping 0 when the count wraps. Both sessions number their offers with it.
constexpr std::uint32_t next_transfer_id(std::uint32_t id) { return id == UINT32_MAX ? 1 : id + 1; }

class TransferSender {
public:
    static constexpr std::size_t kMaxTransfers = 4;
    struct Transfer {
        PlayerId peer = 0;
        std::vector<std::uint8_t> blob;
        SnapshotOfferMessage offer;
        std::uint64_t created_us = 0;
    };
    explicit TransferSender(std::uint64_t lifetime_us) : lifetime_us_(lifetime_us) {}

    // Packs t as a new transfer for `peer`, replacing its previous one, and fills the offer's
    // id, reason, frame, size and hash; the caller may add to the offer before sending it (the
    // reference holds until the next offer()).
    Transfer& offer(PlayerId peer, TransferReason reason, const TransferContents& t, std::size_t input_size, std::uint64_t now_us);
    // The transfer `id` offered to `peer`; nullptr when it expired or is not theirs.
    const Transfer* find(std::uint32_t id, PlayerId peer) const;
    // Chunk `index` of t; false when the index is past the blob.
    static bool chunk(const Transfer& t, std::uint32_t index, SnapshotChunkMessage& out);
    const std::vector<Transfer>& transfers() const { return transfers_; }

private:
    std::uint64_t lifetime_us_;
    std::vector<Transfer> transfers_;
    std::uint32_t next_id_ = 1;
};

class TransferReceiver {
public:
    // The offer must have size <= the caller's limit (checked by the caller).
    explicit TransferReceiver(const SnapshotOfferMessage& offer);

    const SnapshotOfferMessage& offer() const { return offer_; }
    std::uint32_t chunk_count() const { return chunk_count_; }
    // Stores a chunk of this offer; false when it does not belong (other offer, out of range,
    // wrong length for its index), which the caller counts.
    bool add(const SnapshotChunkMessage& chunk);
    bool complete() const { return received_ == chunk_count_; }
    // Distinct chunks stored so far (a repeat counts once): a caller's measure of progress.
    std::uint32_t received() const { return received_; }
    // Chunks to ask for now: missing ones not asked within resend_us, at most `budget`.
    void due_requests(std::uint64_t now_us, std::uint64_t resend_us, int budget, std::vector<std::uint32_t>& out);
    // When complete: the blob if its hash matches the offer, else nullopt (rejected).
    std::optional<std::span<const std::uint8_t>> verified() const;
    std::uint64_t started_us = 0;

private:
    SnapshotOfferMessage offer_;
    std::uint32_t chunk_count_ = 0;
    std::uint32_t received_ = 0;
    std::vector<std::uint8_t> blob_;
    std::vector<bool> have_;
    std::vector<std::uint64_t> asked_us_;
    std::vector<bool> asked_;
};

}  // namespace lockroll::rollback
