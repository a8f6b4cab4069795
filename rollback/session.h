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
//    one DesyncDetected event per (peer, frame), delivered also as SessionObserver::on_desync
//    (the same event, not a second report), then a DesyncReport naming the first differing
//    body/field.
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
//    snapshot the same way (the rule is rollback/arbitration.h's, the relay server's too).
//  - Events for every transition come out of next_event() (requests, not callbacks).
//
// Session is a facade: it owns its state machine (SessionImpl, rollback/session_impl.h, not
// installed) through one pointer and forwards each call, so this installed header names none
// of the internals (Sync, peer links, membership, wire messages). The cost is one indirect call
// per call, nothing per frame beyond it.
//
// Besides Session, this header holds what it is built from and answers with: SessionConfig and
// its validate() (the builder and tools check a config without a session), and SessionQueries,
// the queries both sessions answer alike (RelaySession, rollback/relay_session.h, derives from it
// too).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/events.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/simulation.h>

namespace lockroll::rollback {

class Predictor;    // rollback/predictor.h (in-tree): how missing inputs are guessed
class SessionImpl;  // rollback/session_impl.h (in-tree)
class SessionCore;  // rollback/session_core.h (in-tree)

// ---- SessionConfig: what a Session is told at construction, and validate() ----

// A view of two running players has no strict majority of the other voter: what then.
enum class TwoPlayerRule : std::uint8_t {
    PlayOnAlone,  // either one's vote drops the other: each survivor plays on alone (the default)
    NoDrop,       // nobody is dropped: the one that lost the other reports Partitioned and waits
};
const char* two_player_rule_name(TwoPlayerRule r);

// Two peers disagree and neither is a majority: whose state survives.
enum class DesyncKeep : std::uint8_t { LowestSlot, HighestSlot };

struct SessionConfig {
    int players = 2;                   // 1..kMaxPlayers
    PlayerId local_player = 0;
    std::size_t input_size = 3;        // bytes per player-frame, 1..kMaxInputSize (64)
    int tick_rate = 60;                // Hz; converts times to frames for time sync
    int input_delay = 2;               // frames; set_input_delay() changes it mid-game
    int prediction_window = 8;         // W; 0 = lockstep
    int checksum_interval = 1;         // K: frames whose number is a multiple of K are compared
    int checksum_repeats = 2;          // the newest checksum rides on this many messages
    int evidence_frames = 64;          // confirmed states kept beyond the rollback window
    int max_bad_packets = 8;           // malformed datagrams before a peer is ignored for good
    std::uint32_t input_capacity = 1024;  // frames per input queue (power of two)
    int time_sync_window = 60;         // ticks averaged per recommendation
    int time_sync_min_frames = 2;      // recommend waiting only when this many frames ahead
    int time_sync_every = 8;           // time-sync fields ride on every Nth message
    std::uint64_t query_resend_us = 100000;  // desync narrowing: re-ask after this long
    int max_replies_per_poll = 16;     // per peer: answers beyond this are dropped (re-asked)
    CpuClock cpu_clock;                // telemetry only (CPU per tick, rollback cost); none: 0

    // ---- lifecycle (docs/sessions.md) ----
    // false: every slot not in absent_slots is running from frame 0 with no handshake (the
    // in-process harness); true: hello/welcome and an RTT sync phase come first (real networks).
    bool handshake = false;
    Role role = Role::Player;          // Joiner / Spectator: start from a peer's snapshot
    std::uint64_t match_id = 0;
    std::uint64_t scene_checksum = 0;  // 0: the simulation's initial-state checksum
    std::uint64_t absent_slots = 0;    // bit s: nobody plays slot s at frame 0
    int max_spectators = 0;            // peer ids players .. players + max_spectators - 1
    int sync_roundtrips = 5;           // hello/welcome round trips before frame 0
    bool auto_input_delay = false;     // input delay from the sync phase's RTT
    std::uint64_t hello_resend_us = 50000;
    std::uint64_t interrupt_us = 750000;     // silence before a peer is reported interrupted
    std::uint64_t disconnect_us = 5000000;   // silence before it is dropped (0: never)
    std::uint64_t transfer_resend_us = 250000;  // snapshot offers and chunks re-asked after this
    int transfer_window = 32;          // chunks in flight per transfer
    std::uint32_t max_snapshot_bytes = 64u << 20;
    int max_recoveries = 0;            // desync recoveries before giving up (0: never recover)
    DesyncKeep two_player_keep = DesyncKeep::LowestSlot;
    // Two running processes left in the view have no majority of the other: PlayOnAlone (either
    // one's silence timeout drops the other, and each side plays on alone) or NoDrop (nobody is
    // dropped: the one that lost the other reports Partitioned and waits for it). Every peer
    // must pass the same rule. Three or more: a strict majority of the view, always.
    TwoPlayerRule two_player_rule = TwoPlayerRule::PlayOnAlone;
    int relay_lag = 0;                 // relay a stream to a peer this far behind (0: auto)
    // Names this process in its hellos (0: taken from the first now_us this session sees, which
    // differs between a process and its restarted successor).
    std::uint64_t incarnation = 0;

    // ---- several local players per process (couch + online) ----
    // Empty: every slot is its own process (peer id == slot). Otherwise one entry per slot:
    // slot_hosts[s] is the slot whose process plays s, always the lowest slot of that process
    // (slot_hosts[s] <= s, and a host hosts itself). Every peer passes the same table. A hosted
    // slot (a "guest": slot_hosts[s] != s) has no peer id or connection of its own: its host's
    // session authors its stream (confirmed at once, sent to everyone as stream blocks, like the
    // owner's neutral inputs for absent slots), and it is dropped together with its host. This
    // session plays local_player plus every slot whose host is local_player (local_slots()).
    // Joiners cannot host guests yet.
    std::vector<PlayerId> slot_hosts;
};

// Throws std::invalid_argument "session config: FIELD ..." for the first field that is out of
// range or inconsistent with another, and nothing else; a config it passes constructs a session
// (as far as the config goes: the simulation may still refuse). The builder (net/session_builder)
// and tools check a config with it, without a session.
void validate(const SessionConfig& config);

// ---- SessionQueries ----

// SessionQueries: what both sessions (this P2P Session, the RelaySession) answer alike about
// themselves -- phase, failure, frames, input delay, stalls, recoveries, stats, saved states,
// the event queue and the bit-flip fault hook. Both public facades derive from it; it reads the
// in-tree SessionCore (rollback/session_core.h) their state machines derive from, through a
// pointer the facade sets (in its constructor, and on a rejoin), so this installed header names none of it.
// Every query is the SessionCore's, unchanged; the pointer is set before the facade's
// constructor returns, and again when Session::restart_as_joiner() replaces its state machine;
// it points at the facade's current state machine.
class SessionQueries {
public:
    SessionPhase phase() const;
    bool running() const;
    // Why the session failed (phase() == Failed): "WHERE: WHY"; empty otherwise.
    const std::string& failure() const;
    std::uint32_t frame() const;
    std::uint32_t confirmed_frame() const;
    int input_delay() const;
    bool stalled() const;
    // Snapshot reloads after a desync so far.
    int recoveries() const;
    // Updated in place as the session runs.
    const SessionStats& stats() const;
    // Saved state of a frame while the ring holds it (confirmed frames are final).
    std::optional<std::span<const std::uint8_t>> saved_state(std::uint32_t frame) const;
    // Lifecycle events in order; false when none is left.
    bool next_event(SessionEvent& out) noexcept;
    // Fault injection: every time frame `frame` is produced by a step on this client, flip
    // `bit` of `field` of body `body_id`. Empty string on success, else why not (the frame is
    // already simulated, or the simulation has no such body/field).
    std::string inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit);

protected:
    SessionQueries() = default;
    ~SessionQueries() = default;
    SessionQueries(const SessionQueries&) = delete;
    SessionQueries& operator=(const SessionQueries&) = delete;

    SessionCore* core_ = nullptr;  // the facade's state machine, set by its constructor
};

// ---- Session ----

// Datagram, AdvanceResult, SessionPhase, SlotState, Role, stats: rollback/session_types.h.

// Fault injection on snapshot chunks this session sends (Session::damage_outgoing_chunks).
enum class ChunkDamage : std::uint8_t {
    FlipBit,   // one bit of the chunk's last byte: the right length, so the receiver's hash check
               // of the whole blob must reject the transfer (snapshot_rejected) and ask again
    Truncate,  // the last byte dropped: the receiver's assembler must refuse the chunk and re-ask
};

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
    // Hellos refused: another match, version or scene, a wrong role, a dropped slot, or a restart
    // claimed for a slot whose process still talks (docs/sessions.md, "A restart is a claim").
    std::uint64_t foreign_packets() const;

    // phase(), failure(), frame(), confirmed_frame(), input_delay(), stalled(), recoveries(),
    // stats(), saved_state(), next_event(): SessionQueries' (above).

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
