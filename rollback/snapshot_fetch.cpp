#include "rollback/snapshot_fetch.h"

#include <algorithm>
#include <string>

namespace lockroll::rollback {

bool SnapshotFetch::may_ask(std::uint64_t now_us) const {
    if (incoming_) return false;
    return !offer_requested_ || now_us >= last_ask_us_ + 2 * config_.transfer_resend_us;
}

void SnapshotFetch::newcomer_providers(std::span<const PeerLink> links, std::uint64_t first_welcome_us,
                                       std::uint64_t now_us, std::vector<PlayerId>& out) const {
    out.clear();
    bool ready = false;
    for (int p = 0; p < config_.players; ++p) {
        const PeerLink& l = links[static_cast<std::size_t>(p)];
        if (l.welcomed && l.has_remote_frame && l.roundtrips >= config_.sync_roundtrips) ready = true;
    }
    if (!ready || now_us < first_welcome_us + 3 * config_.hello_resend_us) return;
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        const PeerLink& l = links[pid];
        if (pid == config_.local_player || !l.welcomed || !l.has_remote_frame) continue;
        out.push_back(pid);
    }
    // One host is enough for a spectator: the first that did not serve a rejected snapshot --
    // counted from the one after the host last asked if that ask went unanswered (a host killed
    // before it answered stays welcomed here: asked first again and again, it kept the spectator
    // out for good; issue 21).
    if (config_.role == Role::Spectator && out.size() > 1) {
        auto from = out.begin();
        if (offer_requested_ && asked_) {
            from = std::find_if(out.begin(), out.end(), [&](PlayerId p) { return p > *asked_; });
            if (from == out.end()) from = out.begin();
        }
        std::rotate(out.begin(), from, out.end());
        const auto good = std::find_if(out.begin(), out.end(), [&](PlayerId p) { return p != rejected_provider_; });
        out = {good != out.end() ? *good : out.front()};
    }
}

void SnapshotFetch::ask(std::span<const PlayerId> peers, TransferReason reason, std::uint64_t now_us,
                        std::vector<Datagram>& out) {
    offer_requested_ = true;
    last_ask_us_ = now_us;
    asked_.reset();
    if (peers.size() == 1) asked_ = peers.front();
    for (PlayerId pid : peers) {
        SnapshotRequestMessage r;
        r.reason = reason;
        Datagram d{pid, {}, true};
        encode(r, d.bytes);
        out.push_back(std::move(d));
    }
}

SnapshotFetch::OfferTaken SnapshotFetch::take_offer(PlayerId from, const SnapshotOfferMessage& m, std::uint64_t now_us) {
    if (incoming_) return OfferTaken::Busy;  // a repeat of the current offer changes nothing
    if (m.size > config_.max_snapshot_bytes) return OfferTaken::TooLarge;
    if (m.slots.size() != static_cast<std::size_t>(config_.players)) return OfferTaken::BadSlotTable;
    incoming_ = std::make_unique<TransferReceiver>(m);
    incoming_->started_us = now_us;
    from_ = from;
    progress_chunks_ = 0;
    progress_us_ = now_us;
    asked_.reset();  // answered
    return OfferTaken::Started;
}

bool SnapshotFetch::take_chunk(PlayerId from, const SnapshotChunkMessage& m) {
    return incoming_ && from == from_ && incoming_->add(m);
}

void SnapshotFetch::take_reply(PlayerId from, const ReplyMessage& r) {
    if (r.what == QueryWhat::FrameChecksums && r.count == 1)
        vetting_.on_reply(from, r.frame, r.available && r.values.size() == 1, r.values.empty() ? 0 : r.values[0]);
}

SnapshotFetch::Poll SnapshotFetch::poll(std::uint64_t now_us, std::vector<Datagram>& out) {
    if (!incoming_) return Poll::Nothing;
    if (vetting_.active()) {
        // Asks the voters for their confirmed checksum of the snapshot's frame (resent until they
        // answer); decided either way, finish() takes it from there.
        std::vector<PlayerId> ask;
        vetting_.due(now_us, config_.query_resend_us, ask);
        for (PlayerId p : ask) {
            QueryMessage q;
            q.what = QueryWhat::FrameChecksums;
            q.frame = vetting_.frame();
            q.count = 1;
            Datagram d{p, {}, false};
            encode(q, d.bytes);
            out.push_back(std::move(d));
        }
        return vetting_.verdict(now_us) != SnapshotVetting::Verdict::Pending ? Poll::Decided : Poll::Nothing;
    }
    std::vector<std::uint32_t> due;
    incoming_->due_requests(now_us, config_.transfer_resend_us, config_.transfer_window, due);
    for (std::uint32_t c : due) {
        SnapshotRequestMessage r;
        r.reason = incoming_->offer().reason;
        r.transfer_id = incoming_->offer().transfer_id;
        r.chunk = c;
        Datagram d{from_, {}, true};
        encode(r, d.bytes);
        out.push_back(std::move(d));
    }
    // Progress is a new chunk, seen here (poll runs every tick): repeats and chunks of other
    // offers do not count.
    if (incoming_->received() != progress_chunks_) {
        progress_chunks_ = incoming_->received();
        progress_us_ = now_us;
    }
    const bool stalled = now_us > progress_us_ + kStallResends * config_.transfer_resend_us;
    if (!stalled && now_us <= incoming_->started_us + kTimeoutUs) return Poll::Nothing;
    const std::string got = std::to_string(progress_chunks_) + " of " + std::to_string(incoming_->chunk_count()) +
                            " chunks from peer " + std::to_string(from_);
    why_ = stalled ? "transfer stalled: no new chunk for " + std::to_string((now_us - progress_us_) / 1000) + " ms (" + got + ")"
                   : "transfer timed out: " + got + " in " + std::to_string(kTimeoutUs / 1'000'000) + " s";
    rejected_provider_ = from_;  // gone silent or crawling: asked last next time
    return Poll::TimedOut;
}

void SnapshotFetch::restart() {
    incoming_.reset();
    offer_requested_ = false;
    vetting_.reset();
}

SnapshotFetch::Verdict SnapshotFetch::finish(std::uint64_t now_us, std::span<const PeerLink> links,
                                             const std::function<std::uint64_t(std::span<const std::uint8_t>)>& checksum,
                                             Result& out) {
    out.from = from_;
    out.offer = incoming_->offer();
    out.why.clear();
    out.silent.clear();
    const auto reject = [&](std::string why) {
        out.why = std::move(why);
        restart();
        return Verdict::Rejected;
    };
    const auto blob = incoming_->verified();
    if (!blob) return reject("snapshot transfer: hash mismatch (corrupted or truncated)");
    TransferContents& t = out.contents;
    if (std::string e = unpack_transfer(*blob, state_size_, config_.players, config_.input_size,
                                        config_.input_capacity / 2, t);
        !e.empty())
        return reject(e);
    if (t.frame != out.offer.frame) return reject("snapshot transfer: frame differs from the offer");
    // Join and spectate: loaded only if a strict majority of the view's running processes
    // confirmed the same checksum of that frame (a recovery already follows the majority's checksums).
    if (out.offer.reason != TransferReason::Recover) {
        if (!vetting_.active() || vetting_.frame() != t.frame || vetting_.provider() != from_) {
            // The view as the offer's table gives it, and every peer that welcomed us runs
            // whatever the table says: a provider cannot shrink the view to a minority of its
            // own (or to a view of two, where its word alone may decide). Unless we ourselves
            // have not heard that peer for disconnect_us, the silence a player votes a slot gone
            // on: then the table's word that it left agrees with our own evidence. (Issue 21: a
            // player that welcomed the joiner and was killed before it loaded was counted for
            // good, and the joiner never reached a majority of a view that had dropped it.) To
            // shrink the view past that, a provider must cut us off from the peer too (Left,
            // docs/sessions.md).
            Membership view(config_.players, config_.local_player, config_.two_player_rule, config_.slot_hosts);
            for (const SlotEntry& e : out.offer.slots)
                if (e.slot < static_cast<PlayerId>(config_.players)) view.set(e.slot, e.state, e.epoch);
            for (int s = 0; s < config_.players; ++s) {
                const auto p = static_cast<PlayerId>(s);
                const PeerLink& l = links[p];
                const bool gone_silent = config_.disconnect_us != 0 && l.heard && now_us >= l.last_heard_us &&
                                         now_us - l.last_heard_us >= config_.disconnect_us;
                if (p != config_.local_player && l.welcomed && !gone_silent && !view.running(p))
                    view.set(p, SlotState::Running, view.epoch(p));
            }
            // Short: the slot is handed over already, and a newcomer silent to the others for
            // disconnect_us would be voted gone again. Past it without a majority the offer is
            // rejected and asked for again (never loaded on a minority); a spectator's is not
            // (SnapshotVetting::AtDeadline: it reaches only its host).
            const std::uint64_t wait_us = config_.disconnect_us == 0 ? 2'000'000 : std::min<std::uint64_t>(2'000'000, config_.disconnect_us / 3);
            vetting_.start(t.frame, checksum(t.state), from_, view, now_us, wait_us,
                           config_.role == Role::Spectator ? SnapshotVetting::AtDeadline::AcceptUncontested
                                                           : SnapshotVetting::AtDeadline::Reject);
            return Verdict::Pending;  // poll() asks, and says Decided once it is
        }
        const SnapshotVetting::Verdict v = vetting_.verdict(now_us);
        // A repeated last chunk completes the transfer again while the answers are still coming:
        // that is no verdict (it was taken for a rejection, and a joiner under loss never joined).
        if (v == SnapshotVetting::Verdict::Pending) return Verdict::Pending;
        std::string vetted = vetting_.detail(now_us);
        if (v != SnapshotVetting::Verdict::Accepted) {
            rejected_provider_ = from_;
            out.silent = vetting_.silent(now_us);
            return reject("snapshot rejected: " + vetted);
        }
        out.why = std::move(vetted);
        vetting_.reset();
    }
    incoming_.reset();
    offer_requested_ = false;
    return Verdict::Ready;
}

}  // namespace lockroll::rollback
