// SnapshotServer: the providing side of a P2P snapshot transfer -- a running peer serving a
// joiner, a spectator or a desynced peer -- over the bounded offers of TransferSender
// (rollback/snapshot_transfer.h). Who may be served at all (the owner's handoff, a recovery only
// to a peer seen desynced) is JoinHandoff's rule (rollback/join_handoff.h); this is what a served
// request costs.
//
// Contract
//  - A request for an offer is a claim of a few bytes that costs a whole state packed: the same
//    peer asking again for the same reason while its offer is young gets that offer again
//    (Repeat: 2 s, a recovery 0.3 s, only against duplicates, since it wants a fresh frame), and
//    a recovery is packed afresh at most every kRecoveryIntervalUs (TooSoon). Otherwise Pack.
//    A young offer goes again only while the view it carries (its slot table: each slot's state
//    and epoch) is still the provider's: a newcomer vets a snapshot against the view it names,
//    and a player that died since was named running, so the repeat could only be rejected again
//    (issue 21: a joiner rejected the same offer four times, its handoff lapsed and it loaded
//    2 x disconnect_us later). A view changes rarely (a drop, a join), so this packs at most
//    once more per change.
//  - chunk(): only of a transfer offered to that peer and not expired; an index past the blob is
//    OutOfRange (the peer's fault).
//  - Fault injection (a test hook): damage(count, how) damages the next `count` chunks handed to
//    damage_next(), after any still pending; the kept blob stays intact.
//  - Pure bookkeeping: time comes in, nothing is sent from here.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/session.h"
#include "rollback/snapshot_transfer.h"

namespace lockroll::rollback {

class SnapshotServer {
public:
    static constexpr std::uint64_t kOfferLifetimeUs = 60'000'000;  // each offer kept this long
    static constexpr std::uint64_t kRecoveryIntervalUs = 1'000'000;

    enum class Ask : std::uint8_t { Pack, Repeat, TooSoon };
    // What to do about `peer`'s request for an offer; Repeat: *repeat is the offer to send again.
    // view: the slot table an offer packed now would carry.
    Ask consider(PlayerId peer, TransferReason reason, std::uint64_t now_us, std::span<const SlotEntry> view,
                 const SnapshotOfferMessage** repeat) const;
    // Packs t for `peer` (replacing its previous transfer); the caller completes the offer.
    TransferSender::Transfer& offer(PlayerId peer, TransferReason reason, const TransferContents& t,
                                    std::size_t input_size, std::uint64_t now_us) {
        return sender_.offer(peer, reason, t, input_size, now_us);
    }

    enum class Chunk : std::uint8_t { Ready, NotOurs, OutOfRange };
    Chunk chunk(PlayerId peer, const SnapshotRequestMessage& m, SnapshotChunkMessage& out) const;

    void damage(int count, ChunkDamage how);
    // Damages c if a damage is pending (an empty chunk is left alone and uses none).
    void damage_next(SnapshotChunkMessage& c);
    std::uint64_t damaged_chunks() const { return damaged_; }

private:
    TransferSender sender_{kOfferLifetimeUs};
    std::vector<ChunkDamage> damage_;
    std::uint64_t damaged_ = 0;
};

}  // namespace lockroll::rollback
