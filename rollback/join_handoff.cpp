#include "rollback/join_handoff.h"

#include <algorithm>

#include "rollback/sync.h"

namespace lockroll::rollback {

std::uint32_t JoinHandoff::count_of(PlayerId slot) const { return s_.sync.queue(slot).confirmed_count(); }

void JoinHandoff::request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us) {
    if (m.transfer_id != 0) return chunk(from, m);
    if (!s_.running || s_.config.role == Role::Spectator) return;
    // A recovery is served only to a running player whose confirmed checksums this session has
    // seen differ from its own, and only when recoveries are on: a request is a claim, and
    // answering every one would turn a few bytes into a whole snapshot (an amplifier).
    if (m.reason == TransferReason::Recover &&
        (s_.config.max_recoveries == 0 || !is_slot(from) || !s_.membership.running(from) || !fx_.desynced(from)))
        return ignore(from);
    // The same peer asking again while its offer is young: the same offer (SnapshotServer).
    const SnapshotOfferMessage* repeat = nullptr;
    switch (s_.server.consider(from, m.reason, now_us, &repeat)) {
        case SnapshotServer::Ask::Repeat: {
            std::vector<std::uint8_t> b;
            encode(*repeat, b);
            return fx_.send(from, std::move(b));
        }
        case SnapshotServer::Ask::TooSoon: return ignore(from);
        case SnapshotServer::Ask::Pack: break;
    }
    const std::uint32_t c = s_.sync.confirmed_frame();
    std::uint32_t handoff = 0;
    switch (m.reason) {
        case TransferReason::Join:
            if (!hand_over(from, c, now_us, handoff)) return;
            break;
        case TransferReason::Spectate:
            if (is_slot(from)) return;
            s_.links[from].reset_lifecycle(static_cast<std::size_t>(s_.config.players));
            s_.links[from].mark_heard(now_us);
            fx_.spectator_joined(from, c, now_us);
            break;
        case TransferReason::Recover:
            break;  // checked above
    }
    offer(from, m.reason, c, handoff, now_us);
}

void JoinHandoff::chunk(PlayerId from, const SnapshotRequestMessage& m) {
    SnapshotChunkMessage c;
    switch (s_.server.chunk(from, m, c)) {
        case SnapshotServer::Chunk::NotOurs: return ignore(from);
        case SnapshotServer::Chunk::OutOfRange: return fx_.malformed(from, "snapshot request: chunk out of range");
        case SnapshotServer::Chunk::Ready: break;
    }
    if (s_.replies_this_poll[from] >= kMaxChunksPerPoll) return ignore(from);
    ++s_.replies_this_poll[from];
    s_.server.damage_next(c);
    std::vector<std::uint8_t> b;
    encode(c, b);
    fx_.send(from, std::move(b));
}

// Only the owner hands a slot over, and only once it writes the slot's neutral input (the drop
// is agreed): it picks the handoff frame, far enough ahead that the joiner's first input reaches
// everyone before they need it.
bool JoinHandoff::hand_over(PlayerId from, std::uint32_t frame, std::uint64_t now_us, std::uint32_t& handoff) {
    if (!is_slot(from) || s_.membership.running(from) || !s_.slots[from].authoring) return false;
    // Its last handoff lapsed (SessionImpl::check_handoff): not again before the backoff ends.
    if (now_us < s_.slots[from].next_handoff_us) return false;
    handoff = std::max(count_of(from), fx_.handoff_target(from));
    static const std::vector<std::uint8_t> zeros(kMaxInputSize, 0);
    while (count_of(from) < handoff)
        if (s_.sync.add_remote_input(from, count_of(from), std::span(zeros.data(), s_.config.input_size), true) !=
            InputQueue::Add::Stored)
            return false;  // queue full: not now
    SlotView& v = s_.slots[from];
    // A voter only once its stream starts (Membership: a joiner is no voter until it plays).
    s_.membership.hand_over(from, static_cast<std::uint8_t>(s_.membership.epoch(from) + 1));
    v.new_epoch();
    v.handoff = handoff;
    v.handed_off_by_me = true;
    v.maker = s_.config.local_player;
    PeerLink& l = s_.links[from];
    l.reset_lifecycle(static_cast<std::size_t>(s_.config.players));
    l.welcomed = true;
    l.welcomed_epoch = s_.membership.epoch(from);
    l.mark_heard(now_us);
    fx_.joined(from, handoff, frame, now_us);
    return true;
}

void JoinHandoff::offer(PlayerId from, TransferReason reason, std::uint32_t frame, std::uint32_t handoff,
                        std::uint64_t now_us) {
    TransferContents t;
    if (!s_.sync.transfer_contents(frame, true, t)) return;
    // Old transfers go as this one is packed: bounded memory whatever newcomers ask.
    TransferSender::Transfer& out = s_.server.offer(from, reason, t, s_.config.input_size, now_us);
    out.offer.handoff_frame = handoff;
    for (int s = 0; s < s_.config.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        out.offer.slots.push_back({static_cast<std::uint8_t>(s), s_.membership.state(slot), s_.membership.epoch(slot), 0});
    }
    // Keep what the newcomer will ask us for next: every stream from the snapshot on.
    PeerLink& l = s_.links[from];
    l.pin_from = frame;
    l.pin_until_us = now_us + 30'000'000;
    if (s_.config.role != Role::Spectator && reason != TransferReason::Recover)
        l.remote_ack = count_of(s_.config.local_player);
    std::vector<std::uint8_t> b;
    encode(out.offer, b);
    fx_.send(from, std::move(b));
    fx_.acked();
}

void JoinHandoff::take_view(const SnapshotOfferMessage& offer, Membership& membership, std::span<SlotView> slots,
                            std::span<PeerLink> links, std::uint64_t now_us) {
    for (const SlotEntry& e : offer.slots) {
        SlotView& v = slots[e.slot];
        membership.set(e.slot, e.state, e.epoch);
        v.new_epoch();  // a newcomer has handed nothing over
        v.neutral_reported = e.state != SlotState::Running;
    }
    for (auto& link : links) {
        link.heard = link.welcomed;
        link.last_heard_us = now_us;
        link.interrupted = false;
    }
}

}  // namespace lockroll::rollback
