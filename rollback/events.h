// What a session (P2P or relay) tells its owner while it runs, in two forms:
//  - SessionEvent: one stream of typed lifecycle events, each with the slot or peer it concerns,
//    a frame, a typed reason (SessionEvent::Reason: why, one enum for both sessions) and a
//    detail (the same for a person), drained with next_event() (requests, not callbacks). The stream is
//    bounded (4,096 events held): an owner that never drains it cannot make a session grow
//    without bound; when full the oldest event is dropped, so the newest (the one that says how
//    the session ended) is never lost.
//  - SessionObserver: callbacks for every frame simulated, rollback, confirmation and desync,
//    the hooks the harness measures with and a replay records from (rollback/replay.h).
// A desync is reported once: one DesyncDetected event per (peer, frame), and on_desync is that
// same event delivered as a callback (with both checksums), at the same moment -- not a second
// report. Later facts about it go to its own kinds: DesyncRecovered (this session was the
// minority and reloaded), and NetSession's DesyncReport (narrowing ended).
//
// Frame numbers are state numbers throughout rollback/: "frame n" is the state after n steps
// (sim::World::frame() == n; frame 0 is the initial state), and "the input of frame n" is what
// the step from frame n to n + 1 consumes. Callbacks run synchronously inside Session calls;
// the Simulation is in the state the callback describes, so an observer may read it (positions)
// but must not step, load or call back into the session.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

// ---- the event stream (next_event()) ----

struct SessionEvent {
    enum class Kind : std::uint8_t {
        Synchronizing,   // peer answered a hello (frame: round trips so far)
        Synchronized,    // this session starts frame 0 (or its snapshot frame)
        Refused,         // a handshake failed; detail says why
        Interrupted,     // peer silent for interrupt_us
        Resumed,         // heard again
        Disconnected,    // slot dropped (frame: its inputs held here when dropped)
        Partitioned,     // this session votes others gone but hears no majority of the view: it
                         // drops nobody and stops confirming (frame: its confirmed frame); once
                         // per episode, over when it hears a majority again or a drop is agreed
        NeutralFrom,     // agreed: slot's input is the flagged neutral one from `frame`
        Joined,          // slot (re)joined; frame: the first frame of its own inputs
        SpectatorJoined,
        SnapshotLoaded,  // this session loaded a snapshot of `frame`
        SnapshotRejected,  // a transfer failed verification; asked again
        DesyncDetected,  // frame: first mismatching confirmed frame with `peer`; once per
                         // (peer, frame), the same desync on_desync delivers (relay: one per
                         // server verdict; `peer` is this client's own slot, while on_desync's
                         // is the slot the verdict names to reload from)
        DesyncRecovered, // this session reloaded the majority's state at `frame` (`peer`: whose);
                         // detail: the frame at which it was the minority (or a tie's other side)
        Kicked,          // the others dropped this session's slot
        Failed,          // the session cannot go on; detail says why
        Draining,        // relay: the server is shutting down (the match may finish)
        DesyncReport,    // net::NetSession only (the builder): narrowing ended; peer, frame: the
                         // first differing frame; detail: the summary (body and field when found)
                         // and the evidence file written (desync_report_dir), if any
        ServerLost,      // relay: nothing from the server for server_timeout_us while in the room
                         // (killed, or cut off); detail says how long. The session then fails.
    };
    // Why, as a value an owner can switch on (issue 21: one stream with typed reasons); the
    // detail says the same for a person, with the numbers. Every emit site names one, None
    // where the kind is the whole story. Values are never reordered (reason_name() is stable,
    // and the C ABI hands out the name).
    enum class Reason : std::uint8_t {
        None,
        // Disconnected: why a running slot was dropped, and by which rule: a majority of the
        // view, or (a view of two) the two-player rule, after which this process plays alone.
        TimedOut,                    // silent for disconnect_us
        TimedOutTwoPlayerRule,
        KickVote,                    // disconnect_player(): a kick
        KickVoteTwoPlayerRule,
        HandoffLapsed,               // a joiner handed the slot never took it up
        HandoffLapsedTwoPlayerRule,
        Restarted,                   // its process restarted (a player hello of another process)
        RestartedTwoPlayerRule,
        Rejoining,                   // its process restarted and rejoins by snapshot (a joiner hello)
        RejoiningTwoPlayerRule,
        HostDropped,                 // a guest slot goes with its host's process
        SpectatorTimedOut,           // a spectator went silent (no vote: spectators have none)
        LearnedFromPeer,             // a peer's slot table says so (Joined, Disconnected or Kicked)
        ServerInputAbsent,           // relay: the server marks the slot's input absent
        // Kicked (and the Failed that follows a drop)
        VotedOut,                    // a majority (or the two-player rule) voted this slot gone
        SpectatorDropped,            // a peer says this spectator was dropped
        KickedByServer,              // relay: the server kicked this client
        Dropped,                     // Failed after being dropped; Refused: "you were dropped"
        // Refused: why a hello (ours or a peer's) was not welcomed
        Version,                     // protocol versions differ
        MatchId,                     // another match
        Scene,                       // the initial states' checksums differ
        SlotTaken,                   // the slot is running and the hello is not a rejoin
        Full,                        // no spectator place left
        BadRole,                     // the role does not fit the peer id
        RestartDoubted,              // a restart claimed while the old process is still heard
        // ... and the relay server's refusals (rollback/relay_messages.h, RelayRefusal), beyond
        // Version, SlotTaken and Full (ServerDraining: it is shutting down; KickedByServer: the
        // slot was kicked from this room's match)
        RoomParams,                  // the room exists with other players / input size / tick rate / scene
        BadSlot,                     // slot out of range, or a spectator role naming a slot
        Spoof,                       // this connection already holds another slot
        MatchEnded,                  // the room's match is over
        TokenMissing,                // connect tokens: the hello carries none
        TokenInvalid,                // the token does not open under the server's key
        TokenExpired,                // the token's expiry has passed
        TokenMismatch,               // the token is for another room, slot, role or parameters
        TokenInUse,                  // another live process holds the slot with this token
        SlotOwned,                   // the slot belongs to another client id
        // Interrupted, Resumed, Partitioned
        Silent,                      // nothing heard for interrupt_us
        Heard,                       // heard again
        Reconnected,                 // relay: welcomed again on a new connection
        NoMajority,                  // hears no majority of the view: nobody is dropped
        // Synchronizing, Synchronized, Joined, NeutralFrom
        RoundTrip,                   // a welcome answered our hello
        LateWelcome,                 // a joiner's late welcome from a peer it had not reached
        RelayWelcome,                // relay: the server welcomed this client
        Handshake,                   // started after the handshake (frame 0)
        FromSnapshot,                // started from a loaded snapshot
        Handoff,                     // a joiner took the slot at its handoff frame
        ServerInputsStart,           // relay: the server has the slot's inputs again
        WritesNeutral,               // this peer writes the slot's neutral input
        NeutralAgreed,               // a peer's inputs say where the neutral input starts
        // SnapshotLoaded, SnapshotRejected
        Joining,                     // loaded to join (own inputs from the handoff frame)
        Spectating,                  // loaded to watch
        Recovering,                  // loaded to recover from a desync
        TransferTimedOut,            // the provider went silent; asked again
        TransferInvalid,             // the transfer failed verification; asked again
        TransferLoadFailed,          // verified, but the simulation would not load it
        TransferStalled,             // relay: no progress for too long (Failed)
        // DesyncDetected, DesyncRecovered: who found it, and which rule chose the source
        ChecksumMismatch,            // a peer's confirmed checksum differs from ours
        ServerMinority,              // relay: the server's verdict: this client is in the minority
        ServerNoMajority,            // relay: two players differ, the server's two-player rule ends it
        Majority,                    // this peer was in the minority and reloaded the majority's
        TieRule,                     // no majority (a tie, always so with two): the tie rule chose
        RecoveryLimit,               // Failed: desync and max_recoveries reached
        // Failed, Draining, ServerLost
        RoomMismatch,                // relay: the room's players, input size or tick rate differ
        RoomRestarted,               // relay: the room restarted under this client
        StateTooLarge,               // a saved state exceeds the transfer limit
        OfferTooLarge,               // a snapshot offer exceeds the transfer limit
        Exception,                   // the game (or an invariant) threw inside a session call
        ServerDraining,              // relay: the server is shutting down
        ServerSilent,                // relay: nothing from the server for server_timeout_us
        // Disconnected (a spectator; no vote): it fell spectator_lag_bound inputs behind and no
        // longer holds the players' resend floor (rollback/confirm_floors.h)
        SpectatorLagged,
    };
    Kind kind = Kind::Synchronizing;
    PlayerId peer = 0;        // the slot or peer id concerned
    std::uint32_t frame = 0;
    std::uint64_t at_us = 0;
    std::string detail;
    Reason reason = Reason::None;
};
inline constexpr int kLastReason = static_cast<int>(SessionEvent::Reason::SpectatorLagged);
const char* event_name(SessionEvent::Kind k);
// "timed_out", "kicked_by_server", ...: stable names for logs, the C ABI and its bindings.
const char* reason_name(SessionEvent::Reason r);

// ---- observer callbacks (SessionObserver) ----

struct FrameSimulated {
    std::uint32_t frame = 0;       // the state the simulation now holds (>= 1)
    bool resimulation = false;     // false: the first time this frame was simulated (forward)
    std::uint64_t predicted_mask = 0;        // bit p: player p's input was predicted, not confirmed
    std::span<const std::uint8_t> inputs;    // players * input_size bytes that produced `frame`
};

// A rollback re-runs frames [from_frame, displayed_frame) from the saved state from_frame.
struct RollbackInfo {
    std::uint32_t from_frame = 0;
    std::uint32_t displayed_frame = 0;  // the frame on screen, before and after
    std::uint32_t depth = 0;            // displayed_frame - from_frame
    // Checksums of the displayed frame before and after the correction (equal when the
    // misprediction happened not to matter); only meaningful in on_rollback_end.
    std::uint64_t displayed_checksum_before = 0;
    std::uint64_t displayed_checksum_after = 0;
    bool displayed_changed() const { return displayed_checksum_before != displayed_checksum_after; }
};

// Every frame is confirmed exactly once, in order 1, 2, 3, ...: its inputs are final and its
// state will never change again. This is what replays record and what peers compare.
struct FrameConfirmed {
    std::uint32_t frame = 0;
    std::span<const std::uint8_t> inputs;  // the inputs of frame - 1, players * input_size bytes
    std::uint64_t checksum = 0;            // Simulation::checksum of the saved state `frame`
};

// The checksums of a confirmed frame differ between this client and `peer`. Fired once per
// peer (the first mismatch; every later one is counted in the stats), then narrowing starts.
// It is the DesyncDetected event of the same (peer, frame) as a callback, not a second report.
struct DesyncEvent {
    PlayerId peer = 0;
    std::uint32_t frame = 0;
    std::uint64_t local_checksum = 0;
    std::uint64_t remote_checksum = 0;  // the peer's low 32 bits: all an input message carries
};

// Where narrowing ended. BodyNamed is the goal; the others say why it could not get there.
enum class NarrowOutcome {
    BodyNamed,        // body and field below are filled in
    HeaderOnly,       // every body hash agrees: the difference is in the state header (or in
                      // state the simulation's body_hash() leaves out)
    Unsupported,      // the simulation offers no per-body hashes
    EvidenceMissing,  // this client or the peer no longer holds that frame's state
    NoReply,          // the peer did not answer (gone, or in an error state)
};
const char* narrow_outcome_name(NarrowOutcome o);

struct DesyncReport {
    PlayerId peer = 0;
    std::uint32_t detected_frame = 0;  // the confirmed frame whose checksums disagreed
    std::uint32_t frame = 0;           // first frame found to differ (<= detected_frame)
    std::uint64_t local_checksum = 0;  // at `frame`
    std::uint64_t remote_checksum = 0;
    // Whether remote_checksum is the peer's whole XXH3-64 (from its reply to a frame-checksums
    // query) or only its low 32 bits (from an input message: the detected frame itself, or a
    // peer that never answered). The summary prints only the bits it has.
    bool remote_checksum_full = false;
    NarrowOutcome outcome = NarrowOutcome::Unsupported;
    std::uint32_t body_id = 0;         // BodyNamed: the first diverging body (lowest index)
    int field = -1;                    // BodyNamed: its first differing field, -1 if none found
    std::string field_name;
    std::int64_t local_value = 0;
    std::int64_t remote_value = 0;
    // This client's saved state at `frame` (empty if missing), for the evidence file; render it
    // with Simulation::describe_state. The peer writes its own side when it detects the same
    // mismatch, so two clients' files can be diffed.
    std::vector<std::uint8_t> local_state;
    std::string summary;  // one line a person can read
};

class SessionObserver {
public:
    virtual ~SessionObserver() = default;
    virtual void on_frame_simulated(const FrameSimulated&) {}
    // Before a rollback loads anything: the simulation still holds the displayed frame.
    virtual void on_rollback_begin(const RollbackInfo&) {}
    // After resimulating back to the displayed frame: the simulation holds its corrected state.
    virtual void on_rollback_end(const RollbackInfo&) {}
    virtual void on_frame_confirmed(const FrameConfirmed&) {}
    virtual void on_desync(const DesyncEvent&) {}
    virtual void on_desync_report(const DesyncReport&) {}
    // The peer sent too many malformed packets and is now ignored (sticky).
    virtual void on_peer_error(PlayerId, const std::string& /*last_error*/) {}
};

}  // namespace lockroll::rollback
