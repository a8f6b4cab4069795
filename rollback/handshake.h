// Handshake: a P2P session's hellos and the start of frame 0. A player says hello to every
// running slot's process until frame 0; a newcomer (joiner, spectator) until every running slot
// has welcomed it (sync_roundtrips times while it still synchronizes); a joiner that has not
// loaded greets every other process's slot, since its view is still its config's at frame 0. A player starts frame 0
// once every slot present at start has answered sync_roundtrips hellos -- or, as soon as another
// player has started (a welcome says so, or its inputs arrive), once every one has answered at
// least once: following the first starter at once keeps the starts a one-way trip apart instead
// of a whole sync phase, so time sync has little to even out.
//
// Contract
//  - Which hellos a session welcomes is rollback/session_admission.h; what is done about a hello
//    or a welcome (events, votes, failing, the links changed, the phase change) stays with the
//    session (SessionImpl), which asks the functions below what it means.
//  - Reads the config and the view (both outlive it) and the links it is given; time comes in,
//    hellos go out as datagrams appended to `out`, at most every hello_resend_us per peer
//    (PeerLink::hello_due), unreliable: a hello is said again until answered, and on a reliable
//    channel a lost one would hold back those behind it (SessionImpl::send_control).
//  - The incarnation (which process this is, the same in all its hellos) is config.incarnation,
//    else drawn once from the first poll's time and the local slot.
//  - Hellos received: hello_context() is what admit_hello() (rollback/session_admission.h) is
//    told of the sender, answer() the welcome or refusal it gets (the sender's slot epoch as it
//    is after any drop of a restarted process), new_process() whether a welcomed newcomer's link
//    starts over (another process, another role, a joiner of a slot that changed epoch). A
//    refusal other than Retry is answered at most every 100 ms per peer and reported at most once
//    a second (refusal_answered(), refusal_reported()).
//  - Welcomes received: judge_welcome() says what one means (ignore it, our spectator or slot
//    dropped, refused with the text of the event, one more sync round trip, a running newcomer's
//    late welcome), and whether it tells a player still synchronizing that it is a restarted
//    process (`restarted`: a running slot answered its hello `retry` or `disconnected`); the
//    session does it.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/events.h"
#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/session.h"
#include "rollback/session_admission.h"

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

    // ---- a hello received ----
    // What admit_hello() is told of the sender. running: this session is past its sync phase.
    HelloContext hello_context(PlayerId from, const PeerLink& link, bool running, std::uint64_t scene_checksum,
                               bool handed_off_by_me) const;
    // The answer to hello m: a welcome, or `refusal`.
    WelcomeMessage answer(PlayerId from, const HelloMessage& m, bool running, std::uint64_t scene_checksum,
                          Refusal refusal) const;
    // A welcomed hello of `role` from a process the link does not stand for: forget the previous one.
    bool new_process(PlayerId from, const PeerLink& link, Role role) const;
    static bool refusal_answered(Refusal r, const PeerLink& link, std::uint64_t now_us) {
        return r == Refusal::Retry || link.refusal_quiet_for(now_us, 100'000);
    }
    static bool refusal_reported(const PeerLink& link, std::uint64_t now_us) {
        return link.refusal_quiet_for(now_us, 1'000'000);
    }
    // The Refused event's reason for a refusal (sent or received); None for None and Retry.
    static SessionEvent::Reason refusal_reason(Refusal r);

    // ---- a welcome received ----
    struct WelcomeVerdict {
        enum class Act {
            Ignore,
            SpectatorDropped,  // the peer says this spectator was dropped: kicked, the session fails
            VoteGone,          // the peer dropped our slot: MembershipChanges::refused_as_dropped
            Refused,           // `why` is the event's text; the session fails unless it runs
            SyncRoundTrip,     // one more sync round trip (sync_welcome), then maybe start
            LateWelcome,       // a running newcomer (joiner, spectator) welcomed by a slot it had not reached yet
        };
        Act act = Act::Ignore;
        std::string why;
        SessionEvent::Reason reason = SessionEvent::Reason::None;  // Refused: refusal_reason()
        // A player still synchronizing was answered `retry` or `disconnected` by a running slot:
        // admit_hello says that only to another process of a slot the match runs (its restart
        // claim standing) or dropped, so this process restarted: it had been in the match, and
        // its reach is judged as a joiner's (rollback/joiner_reach.h). Any act.
        bool restarted = false;
    };
    WelcomeVerdict judge_welcome(PlayerId from, const WelcomeMessage& m, SessionPhase phase, const PeerLink& link,
                                 std::uint64_t scene_checksum) const;

    // A player that synchronizes may start frame 0 now.
    bool ready_to_start(std::span<const PeerLink> links, SessionPhase phase) const;
    // Frame 0 starts now: every other player counts as heard now. Returns the worst round trip
    // of the sync phase (the automatic input delay's measure).
    std::uint64_t start(std::span<PeerLink> links, std::uint64_t now_us) const;

private:
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(config_.players); }
    bool counts(PlayerId p) const;  // a slot whose own process must answer: running, not us, no guest

    const SessionConfig& config_;
    const Membership& view_;
    std::uint64_t incarnation_ = 0;
    std::uint64_t first_welcome_us_ = 0;
    bool peer_started_ = false;
};

}  // namespace lockroll::rollback
