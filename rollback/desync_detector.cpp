#include "rollback/desync_detector.h"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <stdexcept>
#include <utility>

namespace lockroll::rollback {

const char* narrow_outcome_name(NarrowOutcome o) {
    switch (o) {
        case NarrowOutcome::BodyNamed: return "body_named";
        case NarrowOutcome::HeaderOnly: return "header_only";
        case NarrowOutcome::Unsupported: return "unsupported";
        case NarrowOutcome::EvidenceMissing: return "evidence_missing";
        case NarrowOutcome::NoReply: return "no_reply";
    }
    return "?";
}

DesyncDetector::DesyncDetector(const DesyncConfig& config, int players, PlayerId local, const Simulation& sim,
                               const SnapshotRing& ring, SessionObserver* observer, SessionStats& stats)
    : config_(config),
      local_(local),
      sim_(sim),
      ring_(ring),
      observer_(observer),
      stats_(stats),
      history_(std::make_unique<Remembered[]>(config.history)),
      peers_(static_cast<std::size_t>(players)) {
    if (config.history < 2 || (config.history & (config.history - 1)) != 0)
        throw std::invalid_argument("checksum history must be a power of two >= 2");
    if (stats_.peers.size() < peers_.size()) stats_.peers.resize(peers_.size());
}

std::optional<std::uint64_t> DesyncDetector::local_checksum(std::uint32_t frame) const {
    const std::size_t i = frame & (config_.history - 1);
    if (history_[i].tag != std::uint64_t{frame} + 1) return std::nullopt;
    return history_[i].checksum;
}

void DesyncDetector::reset_peer(PlayerId peer) {
    if (peer < peers_.size()) peers_[peer] = PeerState{};
}

void DesyncDetector::restart_at(std::uint32_t frame, std::uint64_t checksum) {
    for (PeerState& ps : peers_) {
        ps = PeerState{};
        ps.last_compared_plus1 = frame + 1;
    }
    pinned_.clear();
    std::fill_n(history_.get(), config_.history, Remembered{});
    add_local(frame, checksum);
}

std::optional<std::uint64_t> DesyncDetector::remote_checksum(PlayerId peer, std::uint32_t frame) const {
    if (peer >= peers_.size()) return std::nullopt;
    const PeerState& ps = peers_[peer];
    if (auto it = ps.recent.find(frame); it != ps.recent.end()) return it->second;
    if (auto it = ps.pending.find(frame); it != ps.pending.end()) return it->second;
    if (ps.asked && ps.asked->query.frame == frame && ps.asked_answer) return ps.asked_answer;
    return std::nullopt;
}

void DesyncDetector::ask_checksum(PlayerId peer, std::uint32_t frame) {
    if (peer >= peers_.size() || peer == local_ || remote_checksum(peer, frame)) return;
    PeerState& ps = peers_[peer];
    if (ps.asked && ps.asked->query.frame == frame) {
        // Asked already. Unanswered after max_tries (a cut longer than they span): asked again,
        // for as long as the caller still waits for it.
        if (!ps.asked->received && ps.asked->tries >= config_.max_tries) ps.asked->tries = 0;
        return;
    }
    ps.asked_answer.reset();
    // Assigned, not emplace()d: clang decides optional<Chunk>'s default-constructibility inside
    // DesyncDetector's definition, before Chunk's member initializers, and finds none.
    Chunk chunk;
    chunk.query = {QueryWhat::FrameChecksums, frame, 0, 1};
    ps.asked = std::move(chunk);
}

void DesyncDetector::add_local(std::uint32_t frame, std::uint64_t checksum) {
    const std::size_t i = frame & (config_.history - 1);
    history_[i] = {checksum, std::uint64_t{frame} + 1};
    newest_local_ = frame;
    any_local_ = true;
    for (std::size_t p = 0; p < peers_.size(); ++p) {
        auto& pending = peers_[p].pending;
        while (!pending.empty() && pending.begin()->first <= frame) {
            const auto [f, remote] = *pending.begin();
            pending.erase(pending.begin());
            if (f == frame) compare(static_cast<PlayerId>(p), f, checksum, remote);
        }
    }
}

void DesyncDetector::add_remote(PlayerId peer, std::uint32_t frame, std::uint64_t checksum) {
    if (peer >= peers_.size() || peer == local_) return;
    PeerState& ps = peers_[peer];
    if (frame < ps.last_compared_plus1) return;  // compared already (a repeat or reordered copy)
    if (any_local_ && frame <= newest_local_) {
        if (const auto local = local_checksum(frame)) compare(peer, frame, *local, checksum);
        return;
    }
    ps.pending[frame] = checksum;
    if (ps.pending.size() > config_.max_pending_reports) ps.pending.erase(std::prev(ps.pending.end()));
}

void DesyncDetector::compare(PlayerId peer, std::uint32_t frame, std::uint64_t local, std::uint64_t remote) {
    PeerState& ps = peers_[peer];
    ps.last_compared_plus1 = std::max(ps.last_compared_plus1, frame + 1);
    ps.recent[frame] = remote;
    while (ps.recent.size() > 64) ps.recent.erase(ps.recent.begin());
    // Input messages carry the low 32 bits of each checksum (rollback/protocol.h).
    if (static_cast<std::uint32_t>(local) == static_cast<std::uint32_t>(remote)) {
        ++stats_.peers[peer].checksum_matches;
        if (!ps.desynced) ps.last_agreed = std::max(ps.last_agreed.value_or(0), frame);
        return;
    }
    ++stats_.peers[peer].checksum_mismatches;
    if (ps.desynced) return;
    ps.desynced = true;
    ++stats_.desyncs;
    if (observer_) observer_->on_desync({peer, frame, local, remote});
    start_investigation(peer, frame, local, remote);
}

std::optional<std::span<const std::uint8_t>> DesyncDetector::evidence(std::uint32_t frame) const {
    if (any_local_ && frame <= newest_local_)
        if (auto s = ring_.find(frame)) return s;
    if (auto it = pinned_.find(frame); it != pinned_.end()) return std::span<const std::uint8_t>(it->second);
    return std::nullopt;
}

void DesyncDetector::start_investigation(PlayerId peer, std::uint32_t frame, std::uint64_t local,
                                         std::uint64_t remote) {
    PeerState& ps = peers_[peer];
    ps.report = DesyncReport{};
    ps.report.peer = peer;
    ps.report.detected_frame = ps.report.frame = frame;
    ps.report.local_checksum = local;
    ps.report.remote_checksum = remote;
    if (!evidence(frame)) return finish(peer, NarrowOutcome::EvidenceMissing);
    // Earliest frame that may already differ: just after the last agreement, as far back as we
    // still hold both the state and our checksum.
    const std::uint32_t lowest = ps.last_agreed ? *ps.last_agreed + 1 : 0;
    std::uint32_t first = frame;
    while (first > lowest && frame - first + 1 < static_cast<std::uint32_t>(config_.max_pinned_frames) &&
           evidence(first - 1) && local_checksum(first - 1))
        --first;
    for (std::uint32_t f = first; f <= frame; ++f) {
        if (pinned_.count(f)) continue;
        const auto s = evidence(f);
        pinned_.emplace(f, std::vector<std::uint8_t>(s->begin(), s->end()));
    }
    ps.range_first = first;
    if (first == frame) return begin_body_hashes(peer);
    ps.stage = Stage::FrameChecksums;
    ps.chunks.clear();
    for (std::uint32_t f = first; f < frame; f += kMaxQueryItems) {
        Chunk c;
        c.query = {QueryWhat::FrameChecksums, f, 0,
                   static_cast<std::uint16_t>(std::min<std::uint32_t>(kMaxQueryItems, frame - f))};
        ps.chunks.push_back(std::move(c));
    }
}

void DesyncDetector::begin_body_hashes(PlayerId peer) {
    PeerState& ps = peers_[peer];
    const std::uint32_t n = sim_.body_count();
    if (n == 0) return finish(peer, NarrowOutcome::Unsupported);
    if (!evidence(ps.report.frame)) return finish(peer, NarrowOutcome::EvidenceMissing);
    ps.stage = Stage::BodyHashes;
    ps.chunks.clear();
    for (std::uint32_t i = 0; i < n; i += kMaxQueryItems) {
        Chunk c;
        c.query = {QueryWhat::BodyHashes, ps.report.frame, i,
                   static_cast<std::uint16_t>(std::min<std::uint32_t>(kMaxQueryItems, n - i))};
        ps.chunks.push_back(std::move(c));
    }
}

void DesyncDetector::begin_body_fields(PlayerId peer) {
    PeerState& ps = peers_[peer];
    ps.stage = Stage::BodyFields;
    ps.chunks.clear();
    Chunk c;
    c.query = {QueryWhat::BodyFields, ps.report.frame, ps.body_index, 1};
    ps.chunks.push_back(std::move(c));
}

void DesyncDetector::advance(PlayerId peer) {
    PeerState& ps = peers_[peer];
    switch (ps.stage) {
        case Stage::FrameChecksums:
            for (const Chunk& c : ps.chunks) {
                if (!c.received) return;
                for (std::size_t k = 0; k < c.values.size(); ++k) {
                    const std::uint32_t f = c.query.frame + static_cast<std::uint32_t>(k);
                    const auto local = local_checksum(f);
                    if (!local || *local != c.values[k]) {
                        ps.report.frame = f;
                        ps.report.local_checksum = local.value_or(0);
                        ps.report.remote_checksum = c.values[k];
                        ps.report.remote_checksum_full = true;  // a reply carries all 64 bits
                        return begin_body_hashes(peer);
                    }
                }
            }
            return begin_body_hashes(peer);  // nothing earlier differs: the detected frame it is
        case Stage::BodyHashes: {
            const auto state = evidence(ps.report.frame);
            if (!state) return finish(peer, NarrowOutcome::EvidenceMissing);
            for (const Chunk& c : ps.chunks) {
                if (!c.received) return;
                for (std::size_t k = 0; k < c.values.size(); ++k) {
                    const std::uint32_t index = c.query.start + static_cast<std::uint32_t>(k);
                    if (sim_.body_hash(*state, index) != c.values[k]) {
                        ps.body_index = index;
                        return begin_body_fields(peer);
                    }
                }
            }
            return finish(peer, NarrowOutcome::HeaderOnly);
        }
        case Stage::BodyFields: {
            const Chunk& c = ps.chunks.front();
            if (!c.received) return;
            const auto state = evidence(ps.report.frame);
            if (!state) return finish(peer, NarrowOutcome::EvidenceMissing);
            DesyncReport& r = ps.report;
            r.body_id = sim_.body_id(ps.body_index);
            const int n = std::min(sim_.field_count(), static_cast<int>(c.fields.size()));
            for (int f = 0; f < n; ++f) {
                const std::int64_t mine = sim_.field_value(*state, ps.body_index, f);
                if (mine != c.fields[static_cast<std::size_t>(f)]) {
                    r.field = f;
                    r.field_name = sim_.field_name(f);
                    r.local_value = mine;
                    r.remote_value = c.fields[static_cast<std::size_t>(f)];
                    break;
                }
            }
            return finish(peer, NarrowOutcome::BodyNamed);
        }
        case Stage::None:
        case Stage::Done:
            return;
    }
}

void DesyncDetector::finish(PlayerId peer, NarrowOutcome outcome) {
    PeerState& ps = peers_[peer];
    ps.stage = Stage::Done;
    ps.chunks.clear();
    DesyncReport& r = ps.report;
    r.outcome = outcome;
    if (const auto s = evidence(r.frame)) r.local_state.assign(s->begin(), s->end());
    char buf[512];
    // The peer's checksum as far as it is known: printing a 32-bit value in 16 digits would
    // claim a checksum whose high half is zero.
    char peer_sum[48];
    if (r.remote_checksum_full)
        std::snprintf(peer_sum, sizeof peer_sum, "%016" PRIx64, r.remote_checksum);
    else
        std::snprintf(peer_sum, sizeof peer_sum, "%08" PRIx32 " (low 32 bits)", static_cast<std::uint32_t>(r.remote_checksum));
    int len = std::snprintf(buf, sizeof buf,
                            "desync between player %u and peer %u detected at frame %" PRIu32
                            "; first differing frame %" PRIu32 " (local %016" PRIx64 ", peer %s): ",
                            local_, peer, r.detected_frame, r.frame, r.local_checksum, peer_sum);
    std::string s(buf, static_cast<std::size_t>(std::max(len, 0)));
    switch (outcome) {
        case NarrowOutcome::BodyNamed:
            if (r.field >= 0)
                std::snprintf(buf, sizeof buf, "body %u %s (local %" PRId64 ", peer %" PRId64 ")", r.body_id,
                              r.field_name.c_str(), r.local_value, r.remote_value);
            else
                std::snprintf(buf, sizeof buf, "body %u (hash differs, fields equal)", r.body_id);
            s += buf;
            break;
        // Only as true as body_hash() is complete: say what was compared, not more.
        case NarrowOutcome::HeaderOnly:
            s += "all body hashes agree; the difference is in the state header or in state body_hash() does not cover";
            break;
        case NarrowOutcome::Unsupported: s += "the simulation has no per-body hashes"; break;
        case NarrowOutcome::EvidenceMissing: s += "the state of that frame is no longer held"; break;
        case NarrowOutcome::NoReply: s += "the peer did not answer"; break;
    }
    r.summary = std::move(s);
    if (observer_) observer_->on_desync_report(r);
}

void DesyncDetector::on_reply(PlayerId peer, const ReplyMessage& r) {
    if (peer >= peers_.size()) return;
    PeerState& ps = peers_[peer];
    if (ps.asked && !ps.asked->received && r.what == QueryWhat::FrameChecksums && r.frame == ps.asked->query.frame &&
        r.count == 1) {
        ps.asked->received = true;  // unavailable: not asked again (the 5 s rule leaves it out)
        if (r.available && r.values.size() == 1) ps.asked_answer = r.values[0];
    }
    if (ps.stage == Stage::None || ps.stage == Stage::Done) return;
    for (Chunk& c : ps.chunks) {
        if (c.received || c.query.what != r.what || c.query.frame != r.frame || c.query.start != r.start ||
            c.query.count != r.count)
            continue;
        if (!r.available) return finish(peer, NarrowOutcome::EvidenceMissing);
        c.received = true;
        c.values = r.values;
        c.fields = r.fields;
        return advance(peer);
    }
}

void DesyncDetector::collect_queries(std::uint64_t now_us, std::vector<std::pair<PlayerId, QueryMessage>>& out) {
    for (std::size_t p = 0; p < peers_.size(); ++p) {
        PeerState& ps = peers_[p];
        if (Chunk* c = ps.asked ? &*ps.asked : nullptr;
            c && !c->received && c->tries < config_.max_tries && (c->tries == 0 || now_us - c->last_sent_us >= config_.resend_us)) {
            ++c->tries;
            c->last_sent_us = now_us;
            out.emplace_back(static_cast<PlayerId>(p), c->query);
        }
        if (ps.stage == Stage::None || ps.stage == Stage::Done) continue;
        std::size_t lowest = 0;
        while (lowest < ps.chunks.size() && ps.chunks[lowest].received) ++lowest;
        const std::size_t end = std::min(ps.chunks.size(), lowest + static_cast<std::size_t>(config_.max_outstanding));
        for (std::size_t i = lowest; i < end; ++i) {
            Chunk& c = ps.chunks[i];
            if (c.received) continue;
            if (c.tries > 0 && now_us - c.last_sent_us < config_.resend_us) continue;
            if (c.tries >= config_.max_tries) {
                finish(static_cast<PlayerId>(p), NarrowOutcome::NoReply);
                break;
            }
            ++c.tries;
            c.last_sent_us = now_us;
            out.emplace_back(static_cast<PlayerId>(p), c.query);
        }
    }
}

void DesyncDetector::peer_failed(PlayerId peer) {
    if (peer >= peers_.size()) return;
    const Stage s = peers_[peer].stage;
    if (s == Stage::FrameChecksums || s == Stage::BodyHashes || s == Stage::BodyFields)
        finish(peer, NarrowOutcome::NoReply);
}

bool DesyncDetector::investigating(PlayerId peer) const {
    const Stage s = peers_[peer].stage;
    return s == Stage::FrameChecksums || s == Stage::BodyHashes || s == Stage::BodyFields;
}

ReplyMessage DesyncDetector::answer(const QueryMessage& q) const {
    ReplyMessage r;
    r.what = q.what;
    r.frame = q.frame;
    r.start = q.start;
    r.count = q.count;
    r.available = false;
    switch (q.what) {
        case QueryWhat::FrameChecksums:
            for (std::uint32_t k = 0; k < q.count; ++k) {
                const std::uint32_t f = q.frame + k;
                const auto c = (any_local_ && f <= newest_local_) ? local_checksum(f) : std::nullopt;
                if (!c) {
                    r.values.clear();
                    return r;
                }
                r.values.push_back(*c);
            }
            break;
        case QueryWhat::BodyHashes: {
            const auto state = evidence(q.frame);
            const std::uint32_t n = sim_.body_count();
            if (!state || q.start >= n || q.count > n - q.start) return r;
            for (std::uint32_t k = 0; k < q.count; ++k) r.values.push_back(sim_.body_hash(*state, q.start + k));
            break;
        }
        case QueryWhat::BodyFields: {
            const auto state = evidence(q.frame);
            const int nf = sim_.field_count();
            if (!state || q.start >= sim_.body_count() || nf <= 0 || nf > kMaxFields) return r;
            for (int f = 0; f < nf; ++f) r.fields.push_back(sim_.field_value(*state, q.start, f));
            break;
        }
    }
    r.available = true;
    return r;
}

}  // namespace lockroll::rollback
