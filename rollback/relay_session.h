// RelaySession: one client's side of a match played through the relay server (server/). Sans-IO
// like Session: time comes in as now_us, datagrams go out through poll() (all to the server) and
// come in through receive(), and any Simulation is driven.
//
// How it differs from the peer-to-peer Session (docs/relay.md has the whole story):
//  - The server confirms every input, this client's own too: a local input is a guess until the
//    server's input set for its frame arrives, and when the server replaced it (it came after
//    the deadline) the frame is resimulated like any misprediction. Sync runs with
//    all_streams_remote; the predictor answers the local slot with the input this client sent.
//  - Pacing: the room clock is the match clock. Each frames message carries it; this client
//    estimates it (plus half the round trip), and keeps its shown frame a target lead ahead of
//    it, so its inputs reach the server just before their frame is due:
//        lead = ceil((rtt / 2 + 2 * jitter) / tick) + 1 - input_delay   (may be negative)
//    Ahead of the target: tick_stretch_ppm lengthens ticks; behind it: behind() > 0 and the
//    caller steps catch_up() frames (the local input of a skipped frame repeats the last one).
//  - Input delay (auto_input_delay): rollback/input_delay.h's policy with the whole round trip
//    to the server plus twice the jitter as the input's reach, set from the welcome's round trip
//    and revised every two seconds by at most one frame.
//  - Lifecycle comes from the server: a welcome starts the session (refusals end it with the
//    reason), the frames' flags say when a slot is absent (its neutral input) or replaced.
//    Joiners and spectators pull a snapshot of a confirmed frame from the slot the welcome names,
//    through the server (forwards), then take the confirmed frames after it from the server's
//    history and catch up. A Desync notice (this client's checksum was in the minority) makes it
//    reload the state of the slot the notice names the same way.
//  - Checksums of confirmed frames that are multiples of the room's interval ride on the input
//    messages (each three times); the server arbitrates.
//  - Several local slots (couch + online: RelaySessionConfig::also_slots): one connection, one
//    hello naming them all, one input message per tick whose records carry every local slot's
//    input, in slot order. advance() takes input_size bytes per local slot (local_slots()
//    order); each local slot is predicted with what this client sent for it, and confirmed by
//    the server like any other.
//
// RelaySession is a facade, as Session is: it owns its state machine (RelaySessionImpl,
// rollback/relay_session_impl.h, not installed) through one pointer and forwards each call.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/events.h>
#include <lockroll/rollback/session.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/simulation.h>

namespace lockroll::rollback {

class RelaySessionImpl;  // rollback/relay_session_impl.h (in-tree)

// The server's id in Datagram::peer (poll() addresses everything to it; receive() takes only it).
inline constexpr PlayerId kRelayServerPeer = 0xFFFF;

struct RelaySessionConfig {
    int players = 2;
    PlayerId local_slot = 0;            // ignored for spectators; the lowest local slot
    // Bit s: this client plays slot s too (several local players through the server). Every bit
    // above local_slot and below players; 0 for a spectator.
    std::uint16_t also_slots = 0;
    RelayRole role = RelayRole::Player;
    std::size_t input_size = 3;
    int tick_rate = 60;
    int input_delay = 2;                // frames; overridden by auto_input_delay
    bool auto_input_delay = true;
    int prediction_window = 16;         // W; 0 = lockstep (frames run only once confirmed)
    int evidence_frames = 64;
    std::uint32_t input_capacity = 1024;
    std::uint64_t room_id = 0;
    std::uint64_t scene_checksum = 0;   // 0: the simulation's initial-state checksum
    std::uint16_t absent_slots = 0;     // bit s: nobody plays slot s at frame 0
    // Names this process to the server; a reconnect with the same value resumes its slot, so
    // make it unguessable (random). 0: taken from the first now_us (tests).
    std::uint64_t incarnation = 0;
    // The connect token a backend issued for this slot (server/connect_token.h), sent opaquely
    // in every hello; empty: none (a server without a key). At most kRelayMaxTokenBytes.
    std::vector<std::uint8_t> connect_token;
    std::uint64_t hello_resend_us = 250000;
    std::uint64_t transfer_resend_us = 250000;
    int transfer_window = 32;
    std::uint32_t max_snapshot_bytes = 64u << 20;
    int max_recoveries = 3;             // reloads after Desync notices before giving up
    // Once the room runs (the server sends every tick), this long without a datagram from the
    // server fails the session: "the relay server is silent". 0: wait for ever. A transport
    // reconnect within it resumes the match.
    std::uint64_t server_timeout_us = 5'000'000;
    // A snapshot transfer (join, spectate, recovery) that makes no progress this long (no offer,
    // no new chunk) fails the session, naming the source: a source that is hung, or lies and
    // never serves, must not hold this client in Transferring for ever. 0: wait for ever.
    std::uint64_t transfer_timeout_us = 10'000'000;
    CpuClock cpu_clock;                 // telemetry only (CPU per tick, rollback cost); none: 0
};

// Throws std::invalid_argument naming the field.
void validate(const RelaySessionConfig& config);
// The slots a client with this config plays, bit per slot (none for a spectator).
std::uint16_t relay_local_slots(const RelaySessionConfig& config);

// What the relay did to this client's match, beyond SessionStats.
struct RelayStats {
    std::uint64_t own_replaced = 0;      // frames whose own input the server replaced (late)
    std::uint64_t replaced_any = 0;      // slot-frames replaced, every slot
    std::uint64_t frames_received = 0;   // confirmed frames taken from the server
    std::uint64_t desync_notices = 0;
    std::int64_t lead_x100 = 0;          // shown frame minus the estimated room clock (x100), last tick
    std::int64_t target_lead = 0;        // frames
};

class RelaySession : public SessionQueries {
public:
    // As Session's: simulation, observer and predictor outlive it, the simulation in its
    // initial state (nullptr: no observer / the repeat-last predictor). A bad config throws
    // std::invalid_argument.
    RelaySession(const RelaySessionConfig& config, Simulation& simulation, SessionObserver* observer = nullptr,
                 Predictor* predictor = nullptr);
    ~RelaySession();
    RelaySession(const RelaySession&) = delete;
    RelaySession& operator=(const RelaySession&) = delete;

    // A datagram from the server. Never throws or asserts on its content.
    void receive(std::span<const std::uint8_t> datagram, std::uint64_t now_us) noexcept;
    // One tick: rolls back if needed, then steps once unless the window is full. local_input
    // becomes this client's input of frame() + input_delay() (players only). Input of the wrong
    // size is a caller's bug, counted in stats().bad_local_inputs, and the tick does nothing.
    AdvanceResult advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept;
    // Appends the datagrams for the server: hellos, one input message per tick, forwards.
    void poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept;
    // Behind the target lead (a late start, a joiner, a slow clock): step up to max_frames now.
    int catch_up(std::uint64_t now_us, int max_frames) noexcept;
    // As Session::set_last_frame: no step beyond `frame`, and no own input past it, while
    // rollbacks and confirmations go on. Default: no limit.
    void set_last_frame(std::uint32_t frame);
    // Frames this client is behind its target (0 when on time or ahead).
    std::int32_t behind(std::uint64_t now_us) const;
    // The transport lost the server and connected again: say hello again. The server knows this
    // process by its incarnation and resumes it (same slot, stream and state; no snapshot).
    void transport_reconnected(std::uint64_t now_us);

    const RelaySessionConfig& config() const;
    // The slots this client plays, ascending (empty for a spectator), and the bytes advance()
    // takes: input_size per local slot, in that order (a spectator: one input_size, ignored).
    const std::vector<PlayerId>& local_slots() const;
    std::size_t local_input_size() const;
    // The server holds this client's inputs of every frame before this.
    std::uint32_t server_input_ack() const;
    // The session failed because the server went silent (server_timeout_us): ServerLost.
    bool server_lost() const;
    // This client's id in the room (its slot, or players + place for a spectator).
    int room_id_slot() const;
    std::uint64_t rtt_us() const;
    std::uint64_t jitter_us() const;
    const RelayStats& relay_stats() const;
    // Checksum of a confirmed frame among the newest kConfirmedKept.
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const;
    static constexpr std::uint32_t kConfirmedKept = 4096;

    // phase(), failure(), frame(), confirmed_frame(), input_delay(), stalled(), recoveries(),
    // stats(), saved_state(), next_event(), inject_fault(): SessionQueries' (rollback/session.h).

    // The state machine itself, for tests that look inside: complete only where
    // rollback/relay_session_impl.h is included.
    RelaySessionImpl& impl() { return *impl_; }
    const RelaySessionImpl& impl() const { return *impl_; }

private:
    std::unique_ptr<RelaySessionImpl> impl_;
};

}  // namespace lockroll::rollback
