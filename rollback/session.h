// A rollback/lockstep session: one client's side of an N-player peer-to-peer game.
//
// The session is a pure state machine. It reads no clock (time comes in as now_us, a caller's
// monotonic microsecond count, virtual in the harness), owns no socket (datagrams go out through
// poll() and come in through receive(), addressed by player id), and drives any Simulation.
// So the harness can run N sessions in one process in virtual time, bit-reproducibly, and the
// same code can sit on ENet.
//
// Driving it, per client:
//
//     Session s(config, simulation, &observer);       // observer may be nullptr
//     every tick (1 / tick_rate of that client's clock):
//         for each datagram that arrived:  s.receive(from_player, bytes, now_us);
//         AdvanceResult r = s.advance(local_input_bytes, now_us);   // maybe rolls back, steps
//         s.poll(now_us, outgoing);        // append datagrams; hand each to the transport
//         if (r.wait_frames > 0) skip the next r.wait_frames ticks (time sync) but keep
//             calling receive() and poll() in them.
//
// Semantics (see sync.h for the frame loop, desync_detector.h for alerts):
//  - Frame n is the state after n steps; advance() shows frame() afterwards.
//  - Rollback mode (prediction_window W >= 1): the local input given to advance() belongs to
//    frame() + input_delay and is applied at once; missing remote inputs are predicted; a late
//    input that contradicts a prediction triggers a rollback at the start of the next advance(),
//    before the next frame is shown. With W frames resting on guesses, advance() stalls
//    (returns advanced = false) instead of guessing further.
//  - Lockstep (W = 0): a frame runs only when every input for it is confirmed; never predicts,
//    never rolls back. Choose input_delay >= one-way latency + jitter (in frames) and it runs at
//    the full tick rate (pipelined lockstep).
//  - Inputs travel unreliably and redundantly: each poll() sends every peer all local inputs it
//    has not acknowledged, plus an ack, so loss costs latency, never correctness.
//  - Confirmed-frame checksums ride along every checksum_interval frames; a mismatch fires
//    SessionObserver::on_desync and then a DesyncReport naming the first differing body/field.
//  - Malformed datagrams are counted; after max_bad_packets the peer is ignored for good.
//  - No exceptions across per-tick calls: receive, advance, poll, catch_up and next_event are
//    noexcept. Errors come back as values (counters in stats(), AdvanceResult) or events; what
//    cannot go on (the game's step/save/load threw, an allocation failed) fails the session:
//    phase() == Failed, failure() says where and why, and a `failed` event. Only construction
//    (a bad config) and the commands set_input_delay / disconnect_player (an argument out of
//    range) throw std::invalid_argument.
//
// Lifecycle (docs/sessions.md has the whole story):
//  - Slots. N player slots are fixed at start; each is Absent, Running or Disconnected in a
//    numbered view (state + epoch per slot, rollback/membership.h), plus Interrupted as a local
//    observation of silence. A running slot leaves the view only when a strict majority of the
//    view's running processes votes it gone (two processes: config.two_player_rule); every
//    peer's slot table is its vote, counted only on that peer's own connection, never a fact
//    about others. Joins are the owner's hand-over, adopted from its table. Every slot has one input stream; an absent or disconnected slot's stream is the
//    flagged neutral input written by the slot's owner (the lowest running slot), so every frame
//    still has exactly one confirmed input per slot and confirmation, checksums and replays need
//    no special case.
//  - Handshake (config.handshake): hellos carry protocol version, match id and scene checksum; a
//    mismatch is refused with a reason on both sides. A few hello/welcome round trips measure the
//    RTT before frame 0 (and set the input delay when config.auto_input_delay).
//  - Disconnect: interrupt_us of silence raises Interrupted; disconnect_us of silence (or
//    disconnect_player) is this session's vote that the slot is gone, withdrawn when the slot is
//    heard again; the slot is dropped once a majority votes so. A session whose votes cannot win
//    (it hears no majority of the view) reports Partitioned once, drops nobody and stalls until
//    the network heals. A frame is confirmed only once a majority holds this session's inputs
//    for it, so a minority never confirms what the majority replays with its neutral input.
//    Peers that hold more of its inputs relay them to the others; the owner
//    starts its neutral inputs once every running peer has reported the drop, at the highest
//    count any of them held, so all agree on the frame without a vote.
//  - Join / rejoin / spectate: the newcomer pulls a snapshot of a confirmed frame plus the inputs
//    after it from a running peer (the owner, for a player slot: it also picks the handoff frame
//    from which the newcomer sends its own inputs), loads it, catches up faster than real time
//    (catch_up()), and plays. Nobody pauses.
//  - Desync recovery (max_recoveries > 0): after narrowing, the peer whose confirmed checksum is
//    in the minority (two players: config.two_player_keep decides) reloads the majority's
//    snapshot the same way.
//  - Events for every transition come out of next_event() (requests, not callbacks).
//
// Session is a facade: it owns its state machine (SessionImpl, rollback/session_impl.h, not
// installed) through one pointer and forwards each call, so this installed header names none
// of the internals (Sync, peer links, membership, wire messages). The cost is one indirect call
// per call, nothing per frame beyond it.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/events.h>
#include <lockroll/rollback/player_id.h>
#include <lockroll/rollback/session_config.h>
#include <lockroll/rollback/session_event.h>
#include <lockroll/rollback/session_queries.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/simulation.h>
#include <lockroll/rollback/telemetry.h>

namespace lockroll::rollback {

class Predictor;    // rollback/predictor.h (in-tree): how missing inputs are guessed
class SessionImpl;  // rollback/session_impl.h (in-tree)

// Fault injection on snapshot chunks this session sends (Session::damage_outgoing_chunks).
enum class ChunkDamage : std::uint8_t {
    FlipBit,   // one bit of the chunk's last byte: the right length, so the receiver's hash check
               // of the whole blob must reject the transfer (snapshot_rejected) and ask again
    Truncate,  // the last byte dropped: the receiver's assembler must refuse the chunk and re-ask
};


// Datagram, AdvanceResult, SessionPhase, SlotState, Role: rollback/session_types.h.


// One peer's link as a game's network overlay shows it (GGPO's GGPONetworkStats).
struct NetworkStats {
    std::uint64_t ping_us = 0;       // smoothed round trip
    std::uint64_t jitter_us = 0;     // mean deviation of round-trip samples
    double kbps_sent = 0;            // payload kilobits per second to / from it since the start
    double kbps_received = 0;
    std::int32_t frames_behind = 0;  // how far its displayed frame is estimated behind ours
    std::uint32_t send_queue = 0;    // our inputs it has not acknowledged yet (frames)
    bool interrupted = false;
};


class Session : public SessionQueries {
public:
    // The simulation must be in its initial state and outlive the session, as must the
    // observer and predictor (nullptr: none / repeat-last). Throws std::invalid_argument for a
    // bad config.
    Session(const SessionConfig& config, Simulation& simulation, SessionObserver* observer = nullptr,
            Predictor* predictor = nullptr);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    // A datagram from player `from`. Never throws or asserts on its content.
    void receive(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us) noexcept;
    // One tick: rolls back if needed, then steps once unless the window is full. local_input
    // (input_size bytes per local slot, in the order of local_slots()) becomes the input of
    // frame() + input_delay() if that frame has none yet -- also on a stalled tick, since in
    // lockstep both sides wait for each other's input of the same frame -- and is otherwise not
    // used. Never throws: input of the wrong size is a caller's bug, counted in
    // stats().bad_local_inputs, and the tick does nothing.
    AdvanceResult advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept;
    // Appends the datagrams to send now: one input message per healthy peer, plus desync
    // queries and replies. Call every tick, stalled or not (resends are what beat loss).
    void poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept;

    // Takes effect for the next local input. Growing repeats the last input into the gap;
    // shrinking drops inputs until the delay has caught up (sent inputs never change).
    void set_input_delay(int frames);
    // Switches between rollback (frames >= 1) and lockstep (0) mid-game, up to the configured
    // prediction_window (throws std::invalid_argument beyond it). Peers need not agree: the
    // window is this client's own choice of how far to run on guesses.
    void set_prediction_window(int frames);
    int prediction_window() const;
    // Drops a slot on purpose (a kick): as if it had been silent for disconnect_us.
    void disconnect_player(PlayerId slot, std::uint64_t now_us);
    // A joiner that loaded a snapshot is behind the match: step up to max_frames without taking
    // input (call after advance() while behind() > 0). Returns the frames stepped.
    int catch_up(std::uint64_t now_us, int max_frames) noexcept;
    // The last frame this session simulates (a run of N frames ends on frame N, not beyond):
    // once frame() reaches it, advance() and catch_up() still take inputs, roll back and confirm,
    // but step no further, and a held tick is not a stall. Default: no limit.
    void set_last_frame(std::uint32_t frame);
    // Frames the most advanced running peer is estimated to be ahead of this session.
    std::int32_t behind(std::uint64_t now_us) const;
    // Fault injection (a test hook; `lockroll peer --corrupt-snapshot / --truncate-snapshot`):
    // the next `count` snapshot chunks this session sends, as provider of a join, spectate or
    // recovery transfer, are damaged as `how` says, after any still pending. Its own state and
    // the blob it keeps stay intact, so a chunk asked for again goes out whole once the count is
    // used up. damaged_chunks() counts the chunks damaged so far.
    void damage_outgoing_chunks(int count, ChunkDamage how);
    std::uint64_t damaged_chunks() const;
    // inject_fault() (flip a bit of a body's field each time a frame is stepped): SessionQueries'.

    const SessionConfig& config() const;
    // The slots this session plays, ascending: local_player first, then the slots it hosts
    // (config.slot_hosts). Empty for a spectator. advance() takes one input per entry.
    std::span<const PlayerId> local_slots() const;
    // The slot whose process plays `slot` (itself unless config.slot_hosts says otherwise).
    PlayerId host_of(PlayerId slot) const;
    SlotState slot_state(PlayerId slot) const;
    // Reported Partitioned and not yet heard a majority again.
    bool partitioned() const;
    // Silent longer than interrupt_us (and not dropped yet).
    bool interrupted(PlayerId peer) const;
    std::uint64_t foreign_packets() const;  // other match or version

    // phase(), failure(), frame(), confirmed_frame(), input_delay(), stalled(), recoveries(),
    // stats(), saved_state(), next_event(): SessionQueries' (rollback/session_queries.h).

    // Checksum of a confirmed frame, while remembered.
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const;
    // stats().peers[p].rtt_us / frame_advantage_x100 are refreshed by advance().
    bool peer_error(PlayerId p) const;
    // Smoothed round trip to a peer (µs; 0 until measured).
    std::uint64_t rtt_us(PlayerId p) const;
    // The first of our input frames peer p has not acknowledged: p holds our inputs of every
    // frame before it (so once it is > n and p has everyone else's, p can confirm frame n + 1).
    std::uint32_t peer_ack(PlayerId p) const;
    // Ping, jitter, bandwidth, frames behind and send queue of one peer, for an overlay.
    NetworkStats network_stats(PlayerId p, std::uint64_t now_us) const;
    bool desynced(PlayerId p) const;
    // Frames this client is ahead of the slowest peer (x100), averaged over the window.
    std::int32_t frames_ahead_x100() const;

    // Rejoining after a drop (docs/sessions.md, "Rejoin after a drop"). can_rejoin(): the others
    // dropped this session's slot (it emitted `kicked` and failed) and its process can play the
    // slot again as a joiner (a player or joiner hosting no other slots; not a spectator).
    // restart_as_joiner() does it in place, when can_rejoin() (otherwise it returns false and
    // changes nothing): the session starts again as a joiner of the same slot on the same
    // simulation, observer and predictor, says hello, loads a snapshot of the match vetted by
    // the majority's confirmed checksum, and catches up (catch_up()) while nobody pauses. Its
    // counters (stats()), last frame and prediction window go on; injected faults, chunk damage
    // and events not yet drained do not. References taken from stats(), config() or impl()
    // before it are stale after it. net::PeerRunner and the in-process match call it on a
    // `kicked` (RunnerConfig::rejoin_when_dropped); a game on its own loop may too.
    bool can_rejoin() const;
    bool restart_as_joiner();

    // The state machine itself, for in-tree code and tests that look inside (its membership,
    // links): complete only where rollback/session_impl.h is included.
    SessionImpl& impl() { return *impl_; }
    const SessionImpl& impl() const { return *impl_; }

private:
    std::unique_ptr<SessionImpl> impl_;
    // What the constructor was given, for restart_as_joiner().
    Simulation* simulation_;
    SessionObserver* observer_;
    Predictor* predictor_;
};

}  // namespace lockroll::rollback
