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
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        if (!counts(pid)) continue;
        PeerLink& l = links[pid];
        const bool want = newcomer ? (syncing ? l.roundtrips < config_.sync_roundtrips : !l.welcomed)
                                   : phase == SessionPhase::Synchronizing;
        if (!want) continue;
        if (newcomer && !syncing && config_.role == Role::Spectator) continue;  // a spectator talks to its host only
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
