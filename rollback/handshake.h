// Handshake: a P2P session's hellos and the start of frame 0. A player says hello to every
// running slot's process until frame 0; a newcomer (joiner, spectator) until every running slot
// has welcomed it (sync_roundtrips times while it still synchronizes). A player starts frame 0
// once every slot present at start has answered sync_roundtrips hellos -- or, as soon as another
// player has started (a welcome says so, or its inputs arrive), once every one has answered at
// least once: following the first starter at once keeps the starts a one-way trip apart instead
// of a whole sync phase, so time sync has little to even out.
//
// Contract
//  - Which hellos a session welcomes is rollback/session_admission.h; refusals, the late welcome
//    of a running joiner and the phase change stay with the session (SessionImpl).
//  - Reads the config and the view (both outlive it) and the links it is given; time comes in,
//    hellos go out as datagrams appended to `out`, at most every hello_resend_us per peer
//    (PeerLink::hello_due), unreliable: a hello is said again until answered, and on a reliable
//    channel a lost one would hold back those behind it (SessionImpl::send_control).
//  - The incarnation (which process this is, the same in all its hellos) is config.incarnation,
//    else drawn once from the first poll's time and the local slot.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/session.h"

namespace lockroll::rollback {

class Handshake {
public:
    Handshake(const SessionConfig& config, const Membership& view) : config_(config), view_(view) {}

    // The hellos due now (phase: the session's).
    void poll_hellos(std::span<PeerLink> links, SessionPhase phase, std::uint64_t scene_checksum, std::uint64_t now_us,
                     std::vector<Datagram>& out);
    std::uint64_t incarnation() const { return incarnation_; }

    // A welcome received while synchronizing (not a refusal): one more round trip with that peer.
    void sync_welcome(PeerLink& link, bool from_slot, const WelcomeMessage& m, std::uint64_t now_us);
    // Another player plays already (its inputs arrived): follow it.
    void peer_started() { peer_started_ = true; }
    // When the first welcome came (0: none yet): a newcomer gives the others a moment from there.
    std::uint64_t first_welcome_us() const { return first_welcome_us_; }

    // A player that synchronizes may start frame 0 now.
    bool ready_to_start(std::span<const PeerLink> links, SessionPhase phase) const;
    // Frame 0 starts now: every other player counts as heard now. Returns the worst round trip
    // of the sync phase (the automatic input delay's measure).
    std::uint64_t start(std::span<PeerLink> links, std::uint64_t now_us) const;

private:
    bool counts(PlayerId p) const;  // a slot whose own process must answer: running, not us, no guest

    const SessionConfig& config_;
    const Membership& view_;
    std::uint64_t incarnation_ = 0;
    std::uint64_t first_welcome_us_ = 0;
    bool peer_started_ = false;
};

}  // namespace lockroll::rollback
