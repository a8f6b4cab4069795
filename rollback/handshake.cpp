#include "rollback/handshake.h"

#include <algorithm>

#include "rollback/slot_hosts.h"

namespace lockroll::rollback {

bool Handshake::counts(PlayerId p) const {
    return p != config_.local_player && view_.running(p) && host_of(config_, p) == p;
}

void Handshake::poll_hellos(std::span<PeerLink> links, SessionPhase phase, std::uint64_t scene_checksum,
                            std::uint64_t now_us, std::vector<Datagram>& out) {
    if (incarnation_ == 0) incarnation_ = config_.incarnation != 0 ? config_.incarnation : (now_us << 8 | config_.local_player) + 1;
    const bool newcomer = config_.role != Role::Player;
    const bool syncing = phase == SessionPhase::Synchronizing || phase == SessionPhase::Transferring;
    // A joiner that has not loaded knows the view only as its config had it at frame 0: a slot
    // absent then, or dropped since, may run now, and its process must welcome us before it
    // answers our snapshot's vetting query. (Issue 21: a rejoiner of slot 2 never said hello to
    // slot 1, which had joined after slot 2's kill; slot 1 ignored its queries, and the rejoiner
    // never loaded.) So until it runs it says hello to every other process's slot; one with no
    // process never answers, and none of them is waited for (the offer is asked of those that
    // welcomed us).
    const bool stale_view = config_.role == Role::Joiner && phase != SessionPhase::Running;
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        const bool maybe_running = stale_view && pid != config_.local_player && host_of(config_, pid) == pid;
        if (!counts(pid) && !maybe_running) continue;
        PeerLink& l = links[pid];
        const bool want = newcomer ? (syncing ? l.roundtrips < config_.sync_roundtrips : !l.welcomed)
                                   : phase == SessionPhase::Synchronizing;
        // A running spectator too: served only by the players that welcomed it, it would stop for
        // good once they all left -- its host killed before the others' welcomes came (issue 21).
        if (!want) continue;
        if (!l.hello_due(now_us, config_.hello_resend_us)) continue;
        HelloMessage h;
        h.incarnation = incarnation_;
        h.match_id = config_.match_id;
        h.scene_checksum = scene_checksum;
        h.role = config_.role;
        h.stamp_us = now_us;
        Datagram d{pid, {}, false};  // unreliable, as SessionImpl::send_control says why
        encode(h, d.bytes);
        out.push_back(std::move(d));
    }
}

void Handshake::sync_welcome(PeerLink& link, bool from_slot, const WelcomeMessage& m, std::uint64_t now_us) {
    if (link.sync_welcome(m.echo_us, m.running, now_us) && first_welcome_us_ == 0) first_welcome_us_ = now_us == 0 ? 1 : now_us;
    if (m.running && from_slot) peer_started_ = true;
}

HelloContext Handshake::hello_context(PlayerId from, const PeerLink& link, bool running, std::uint64_t scene_checksum,
                                      bool handed_off_by_me) const {
    HelloContext c;
    c.match_id = config_.match_id;
    c.scene_checksum = scene_checksum;
    c.from = from;
    c.from_slot = is_slot(from);
    c.running = running;
    c.welcomed = link.welcomed;
    c.incarnation = link.incarnation;
    if (c.from_slot) {
        c.slot_running = view_.running(from);
        c.welcomed_in_this_epoch = link.welcomed_epoch == view_.epoch(from);
        c.handed_off_by_me = handed_off_by_me;
    }
    return c;
}

WelcomeMessage Handshake::answer(PlayerId from, const HelloMessage& m, bool running, std::uint64_t scene_checksum,
                                 Refusal refusal) const {
    WelcomeMessage w;
    w.match_id = config_.match_id;
    w.scene_checksum = scene_checksum;
    w.echo_us = m.stamp_us;
    w.running = running;
    if (is_slot(from)) w.slot_epoch = view_.epoch(from);
    w.refusal = refusal;
    return w;
}

// A player's hellos come from the process welcomed at start (a restarted one is refused and
// rejoins as a joiner), so only a newcomer's link starts over.
bool Handshake::new_process(PlayerId from, const PeerLink& link, Role role) const {
    if (role == Role::Player) return false;
    return !link.welcomed || link.role != role ||
           (is_slot(from) && role == Role::Joiner && !view_.running(from) && link.welcomed_epoch != view_.epoch(from));
}

SessionEvent::Reason Handshake::refusal_reason(Refusal r) {
    using R = SessionEvent::Reason;
    switch (r) {
        case Refusal::None:
        case Refusal::Retry: return R::None;
        case Refusal::Version: return R::Version;
        case Refusal::MatchId: return R::MatchId;
        case Refusal::Scene: return R::Scene;
        case Refusal::SlotTaken: return R::SlotTaken;
        case Refusal::Full: return R::Full;
        case Refusal::Disconnected: return R::Dropped;
        case Refusal::BadRole: return R::BadRole;
    }
    return R::None;
}

Handshake::WelcomeVerdict Handshake::judge_welcome(PlayerId from, const WelcomeMessage& m, SessionPhase phase,
                                                   const PeerLink& link, std::uint64_t scene_checksum) const {
    using Act = WelcomeVerdict::Act;
    const bool running = phase == SessionPhase::Running;
    // A player's hello is answered retry or disconnected only when the match runs with another
    // process of its slot, or dropped it (admit_hello): this one restarted. A first start is
    // welcomed (or refused for a mismatch), never told either.
    const bool restarted = config_.role == Role::Player && phase == SessionPhase::Synchronizing && is_slot(from) && m.running &&
                           (m.refusal == Refusal::Retry || m.refusal == Refusal::Disconnected);
    if (m.refusal == Refusal::Retry) return {Act::Ignore, {}, SessionEvent::Reason::None, restarted};
    if (m.refusal == Refusal::Disconnected) {
        if (config_.role == Role::Spectator) return {Act::SpectatorDropped, {}};
        // One voice, which makes us Kicked only together with a majority (in a view of two, the
        // other's decision made: MembershipChanges::refused_as_dropped). A joiner still
        // synchronizing has no slot in the view to lose yet.
        if (config_.role == Role::Player || running) return {Act::VoteGone, {}, SessionEvent::Reason::None, restarted};
        return {};
    }
    if (m.refusal != Refusal::None) {
        std::string why = std::string("peer ") + std::to_string(from) + " refused: " + refusal_name(m.refusal);
        if (m.refusal == Refusal::MatchId)
            why += " (theirs " + std::to_string(m.match_id) + ", ours " + std::to_string(config_.match_id) + ")";
        if (m.refusal == Refusal::Scene)
            why += " (theirs " + std::to_string(m.scene_checksum) + ", ours " + std::to_string(scene_checksum) + ")";
        return {Act::Refused, std::move(why), refusal_reason(m.refusal)};
    }
    if (running) {
        // A newcomer that loaded its snapshot from one peer may reach another only afterwards
        // (between processes: that peer's connection came up late). Its hellos go on until every
        // running slot has welcomed it; the late welcome makes the link live, so the two exchange
        // inputs from now on (without it each would ignore the other: the peer would drop a
        // joiner's slot for silence, and a spectator would be served by its host alone and stop
        // for good if that host died).
        if (config_.role == Role::Player || !is_slot(from) || !view_.running(from) || !m.running || link.welcomed) return {};
        return {Act::LateWelcome, {}};
    }
    if (phase != SessionPhase::Synchronizing && phase != SessionPhase::Transferring) return {};
    return {Act::SyncRoundTrip, {}};
}

bool Handshake::ready_to_start(std::span<const PeerLink> links, SessionPhase phase) const {
    if (config_.role != Role::Player || phase != SessionPhase::Synchronizing) return false;
    const int needed = peer_started_ ? 1 : config_.sync_roundtrips;
    for (int p = 0; p < config_.players; ++p)
        if (counts(static_cast<PlayerId>(p)) && links[static_cast<std::size_t>(p)].roundtrips < needed) return false;
    return true;
}

std::uint64_t Handshake::start(std::span<PeerLink> links, std::uint64_t now_us) const {
    std::uint64_t worst = 0;
    for (int p = 0; p < config_.players; ++p)
        if (static_cast<PlayerId>(p) != config_.local_player) {
            worst = std::max(worst, links[static_cast<std::size_t>(p)].max_sync_rtt_us);
            links[static_cast<std::size_t>(p)].mark_heard(now_us);
        }
    return worst;
}

}  // namespace lockroll::rollback
