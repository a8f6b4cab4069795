// SnapshotFetch: the receiving side of a P2P snapshot transfer -- a newcomer (joiner, spectator)
// loading the match, or a desynced peer reloading the majority's state. It decides whom to ask
// and when, takes one offer at a time, pulls its chunks, verifies the blob, and for a join or
// spectate vets the state against the majority's confirmed checksum (rollback/snapshot_vetting.h)
// before handing it to the session to load (SessionImpl::finish_transfer).
//
// Contract
//  - Pure bookkeeping: time comes in, messages go out as datagrams appended to `out`, nothing is
//    loaded here. No clock, no sim/ types (the state's checksum is the caller's function).
//  - One transfer at a time: another offer while one is under way is ignored. An offer is taken
//    only if its size is within config.max_snapshot_bytes and its slot table has config.players
//    entries; a chunk only from the offer's sender and of that offer.
//  - Offers are asked for at most every 2 x transfer_resend_us while none arrives (may_ask).
//    A transfer is dropped and asked for again (poll: TimedOut, why() says which), its provider
//    asked last, when no new chunk came for kStallResends x transfer_resend_us (a provider that
//    died or was cut off midway: issue 21), or at the latest kTimeoutUs after its offer (one
//    that trickles chunks just fast enough never to stall). A spectator whose ask went
//    unanswered asks the next host (a host may die between its welcome and its offer).
//  - finish(): a complete transfer whose hash, contents or frame are wrong is Rejected, and so is
//    a vetted one the majority contradicts or, for a joiner, no majority confirmed by the
//    vetting's deadline (a spectator's uncontested host is enough there: SnapshotVetting) --
//    its provider is then asked last (rejected_provider), the reason names the silent voters
//    (and Result::silent lists them: rollback/joiner_reach.h);
//    every rejection forgets the transfer so the next ask goes out at once. Join and spectate
//    wait (Pending) for the vetting's verdict; a recovery needs none (it already follows the
//    majority's checksums). Ready hands out the contents and forgets the transfer.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/peer_link.h"
#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/snapshot_transfer.h"
#include "rollback/snapshot_vetting.h"

namespace lockroll::rollback {

class SnapshotFetch {
public:
    // A transfer under way with no new chunk for this many resend periods is dropped (issue 21:
    // a provider that died midway kept the newcomer kTimeoutUs). Each period re-asks every
    // missing chunk the window holds (32), so while a live provider has chunks to send, a whole
    // period passes without a new one only if every one of those round trips was lost; at the
    // end, with one chunk missing, a round trip at 20 % loss each way fails 36 % of the time,
    // and 8 periods in a row 0.36^8 = 3e-4 of the time (tests/rollback/snapshot_fetch_test.cpp:
    // 40 transfers of 200 chunks at that loss, none dropped with 8, one with 4, five with 2).
    // 8 x 250 ms = 2 s is also far above any round trip a match plays on, and a newcomer whose
    // provider died asks the next one 2 s later instead of 20 s.
    static constexpr std::uint64_t kStallResends = 8;
    // The whole transfer's bound, from its offer: a provider that sends a chunk now and then,
    // never stalling, still cannot keep the newcomer for good. It also bounds what can be
    // loaded at all (32 chunks of 1 KiB per round trip for 20 s: some 10 MiB at 60 ms), as
    // before the stall rule.
    static constexpr std::uint64_t kTimeoutUs = 20'000'000;

    // config outlives this; state_size: the simulation's.
    SnapshotFetch(const SessionConfig& config, std::size_t state_size) : config_(config), state_size_(state_size) {}

    // No transfer under way and no offer asked for lately.
    bool may_ask(std::uint64_t now_us) const;
    // Whom a newcomer asks for an offer (appended to out; nothing yet: empty): once some peer has
    // welcomed it sync_roundtrips times and the others had three hello periods since the first
    // welcome to answer, every welcomed peer that reported its frame -- a spectator only one,
    // the first that did not serve a rejected snapshot (or time out its transfer), counted from
    // the one after its last host when that host's offer never came.
    void newcomer_providers(std::span<const PeerLink> links, std::uint64_t first_welcome_us, std::uint64_t now_us,
                            std::vector<PlayerId>& out) const;
    // Asks each of `peers` for an offer now.
    void ask(std::span<const PlayerId> peers, TransferReason reason, std::uint64_t now_us, std::vector<Datagram>& out);
    // Another source was picked (a recovery): the next ask need not wait.
    void ask_again() { offer_requested_ = false; }

    enum class OfferTaken : std::uint8_t { Started, Busy, TooLarge, BadSlotTable };
    OfferTaken take_offer(PlayerId from, const SnapshotOfferMessage& m, std::uint64_t now_us);
    // False when it is not a chunk of the transfer under way (the caller counts it ignored).
    bool take_chunk(PlayerId from, const SnapshotChunkMessage& m);
    bool complete() const { return incoming_ && incoming_->complete(); }
    // A voter's confirmed checksum of the snapshot's frame (a Reply while vetting).
    void take_reply(PlayerId from, const ReplyMessage& r);
    bool vetting() const { return vetting_.active(); }

    enum class Poll : std::uint8_t { Nothing, TimedOut, Decided };
    // Chunk requests and vetting queries due now. Decided: the vetting has a verdict (call
    // finish()); TimedOut: the transfer stalled or took too long (why() says which; the caller
    // tells, forgets it with restart(), and asks again).
    Poll poll(std::uint64_t now_us, std::vector<Datagram>& out);
    // Why the last poll said TimedOut.
    const std::string& why() const { return why_; }

    enum class Verdict : std::uint8_t { Pending, Rejected, Ready };
    struct Result {
        PlayerId from = 0;
        SnapshotOfferMessage offer;
        TransferContents contents;  // Ready
        std::string why;            // Rejected: what was wrong; Ready: the vetting's detail
        std::vector<PlayerId> silent;  // Rejected at the vetting's deadline: the voters that did not answer
    };
    // Call once complete(). links: who was welcomed (a voter even if its slot does not run yet).
    Verdict finish(std::uint64_t now_us, std::span<const PeerLink> links,
                   const std::function<std::uint64_t(std::span<const std::uint8_t>)>& checksum, Result& out);
    // Forget the transfer under way (a load that failed after Ready is the caller's rejection).
    void restart();

    // The transfer under way, if any.
    const TransferReceiver* incoming() const { return incoming_.get(); }
    PlayerId provider() const { return from_; }
    std::optional<PlayerId> rejected_provider() const { return rejected_provider_; }

private:
    const SessionConfig& config_;
    std::size_t state_size_;
    std::unique_ptr<TransferReceiver> incoming_;
    PlayerId from_ = 0;
    std::uint64_t last_ask_us_ = 0;
    bool offer_requested_ = false;
    SnapshotVetting vetting_;
    std::optional<PlayerId> rejected_provider_;
    std::optional<PlayerId> asked_;  // the one provider of the last ask, until its offer came
    std::uint32_t progress_chunks_ = 0;  // chunks the transfer under way had at progress_us_
    std::uint64_t progress_us_ = 0;      // when it last gained one (its offer's arrival at first)
    std::string why_;                    // of the last TimedOut
};

}  // namespace lockroll::rollback
