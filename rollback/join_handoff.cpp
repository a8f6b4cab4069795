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
    // The same peer asking again while its offer is young and our view unchanged: the same offer
    // (SnapshotServer).
    const SnapshotOfferMessage* repeat = nullptr;
    switch (s_.server.consider(from, m.reason, now_us, view_table(), &repeat)) {
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

std::vector<SlotEntry> JoinHandoff::view_table() const {
    std::vector<SlotEntry> t;
    for (int s = 0; s < s_.config.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        t.push_back({static_cast<std::uint8_t>(s), s_.membership.state(slot), s_.membership.epoch(slot), 0});
    }
    return t;
}

// Only the owner hands a slot over, and only once it writes the slot's neutral input (the drop
// is agreed): it picks the handoff frame, far enough ahead that the joiner's first input reaches
// everyone before they need it.
bool JoinHandoff::hand_over(PlayerId from, std::uint32_t frame, std::uint64_t now_us, std::uint32_t& handoff) {
    if (!is_slot(from)) return false;
    if (s_.membership.running(from)) return serve_again(from, handoff);
    if (!s_.slots[from].authoring) return false;
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

// Our own handoff of `from`, still pending (its stream has not started here, and we do not vote
// it gone): the same decision -- epoch, handoff frame, the neutral input up to it that we wrote --
// offered again with our confirmed frame's state and our view as it is now. That frame is at most
// the handoff frame (nothing past it is confirmed without the joiner's input), and the streams
// from it include our neutral input up to the handoff frame, so the joiner plays from the same
// frame as before. Issue 21: a player that died during a handoff was named running in the only
// offer the owner would make, so the joiner's vetting could never pass, the handoff lapsed, and
// the next one came 2 x disconnect_us later. Nobody else serves it: only the maker knows the
// handoff frame and wrote the neutral input up to it.
bool JoinHandoff::serve_again(PlayerId from, std::uint32_t& handoff) const {
    const SlotView& v = s_.slots[from];
    if (!v.handed_off_by_me || !s_.membership.joining(from) || stream_started(s_.sync.queue(from)) ||
        s_.membership.vote_of(s_.config.local_player, from) == Vote::Gone)
        return false;
    if (s_.sync.confirmed_frame() > v.handoff) return false;  // cannot happen (above): never offer past it
    handoff = v.handoff;
    return true;
}

void JoinHandoff::offer(PlayerId from, TransferReason reason, std::uint32_t frame, std::uint32_t handoff,
                        std::uint64_t now_us) {
    TransferContents t;
    if (!s_.sync.transfer_contents(frame, true, t)) return;
    // Old transfers go as this one is packed: bounded memory whatever newcomers ask.
    TransferSender::Transfer& out = s_.server.offer(from, reason, t, s_.config.input_size, now_us);
    out.offer.handoff_frame = handoff;
    out.offer.slots = view_table();
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
