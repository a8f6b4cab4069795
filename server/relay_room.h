// RelayRoom: one match on the relay server. It runs no simulation: it collects each slot's
// inputs, confirms frames in order, broadcasts the confirmed input sets, arbitrates checksums,
// and routes snapshot transfers between its clients.
//
// Contract
//  - Clock: the room clock starts when every slot not absent at frame 0 has a player; its frame
//    is (now - start) * tick_rate. It is the match clock: clients pace themselves against it.
//  - Confirmation: frame f (the next unconfirmed one) is confirmed as soon as every running
//    slot's input for f is in, or once the clock reaches f + input_deadline. A running slot
//    whose input is then missing gets its last confirmed input again, flagged Replaced (its own
//    input, arriving later, is dropped and counted as late). A slot nobody plays (absent, left,
//    or joining before its handoff frame) gets the neutral input (zeros), flagged Absent. So
//    every client receives exactly the same input set for every frame, its own slot included,
//    and nobody waits on a slow player past the deadline.
//  - Broadcast: each connection is sent the frames from its acknowledgement on, delta coded and
//    as many as fit one datagram, as soon as frames are confirmed (once per batch of received
//    datagrams: send_pending()) and at least once per tick (which also carries the clock and the
//    input acknowledgement). Loss costs latency only.
//  - History: confirmed frames are kept for history_s (at least the snapshot window), so a
//    joiner, a reconnecting player or a spectator that loaded a snapshot of a recent frame gets
//    every frame after it from the room.
//  - Checksums: clients report confirmed checksums of multiples of checksum_interval. Once every
//    running slot reported a frame (or checksum_timeout_frames later), the checksums are
//    arbitrated by rollback/arbitration.h (the rule P2P recovery uses): the majority value wins;
//    a slot in the minority is sent a Desync notice naming a majority slot to reload from.
//    No majority between two voters (a round whose only two reports disagree, in a room of two
//    running connections): RoomConfig::two_player_desync decides. EndMatch (the default): both
//    are sent a Desync notice naming kRelayNoMajority, and fail "no majority"; the room decides
//    no more rounds. KeepLowestSlot: P2P's DesyncKeep::LowestSlot, the higher slot reloads from
//    the lower. Three or more voters split with no strict majority: the biggest group wins, and
//    among equally big ones the group of the lowest slot.
//  - Liars: a connection in the minority against a strict majority (3+ voters) in
//    max_minority_rounds decided rounds in a row is handed to the server to kick
//    (take_kicks()), after a Kicked notice. Its slots are then banned for the rest of the
//    match: a hello naming one is refused (RelayRefusal::Kicked), so neither the kicked process
//    (whose transport reconnects) nor a newcomer takes it back; it plays the absent input. Its
//    streak restarts at 0 when a decided round finds it with the winning value, and when its
//    slot is bound to a new process; `desyncs` counts every verdict and never resets.
//  - Joins: a hello for an absent or departed slot (or a held slot whose connection has been
//    silent for replace_silent_us: a restarted process) binds it with a handoff frame a little
//    ahead of the clock; its inputs count from there. Spectators take places after the slots.
//    Both are told which slot to pull a snapshot from (the lowest connected player).
//  - Lapse: a slot bound to a running room whose connection sends no input of its own by
//    input_from + silence_drop_us (a joiner that never loads, however alive its keepalives)
//    plays the absent input from then on, as if nobody held it: nobody waits for it at every
//    frame's deadline. The first input it sends later (a frame not confirmed yet) makes that
//    frame its new input_from; a connection that stays silent leaves as any silent one does.
//  - Several slots per connection (couch + online): a hello names its slots (RelayHello::slot,
//    the lowest, and also_slots). It is admitted whole or refused whole: every slot in range,
//    each free, its own (the same incarnation: a resume), or held by one silent connection
//    whose slots it then takes over (that connection's other slots leave with it). The
//    connection is known by its lowest slot (slot_of(), welcomes, forwards, desync verdicts);
//    its Input records carry every one of its slots' inputs, in slot order, and are taken only
//    if their slots mask is exactly the connection's (anything else is bad, and ignored:
//    identity comes from the connection, never from a field). Acks, stamps, silence and the
//    Frames it is sent are per connection; checksums are one vote per connection, so a
//    machine with two local players does not outvote one with one.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "rollback/relay_messages.h"
#include "server/frame_history.h"
#include "server/outbox.h"

namespace lockroll::server {

using rollback::RelayRefusal;

// Two voters whose checksums disagree: neither is a majority (contract below, docs/relay.md).
enum class TwoPlayerDesync : std::uint8_t {
    EndMatch,        // both are told no majority can settle it: the match ends for both
    KeepLowestSlot,  // P2P's DesyncKeep::LowestSlot: the higher slot reloads from the lower
};

struct RoomConfig {
    int input_deadline = 8;                 // ticks past a frame's time before inputs are replaced
    int checksum_interval = 60;             // frames; 0: no arbitration
    int checksum_timeout_frames = 120;      // decide without the missing reports after this
    double history_s = 600;                 // confirmed frames kept (late join, reconnect)
    int max_frames_ahead = 240;             // inputs beyond clock + this are out of window
    int max_spectators = 4;
    std::uint64_t silence_drop_us = 5'000'000;   // a slot silent this long has left
    std::uint64_t replace_silent_us = 1'000'000; // a held slot may be taken over after this silence
    int handoff_ticks = 30;                 // a joiner's inputs start this far ahead of the clock
    TwoPlayerDesync two_player_desync = TwoPlayerDesync::EndMatch;  // two voters disagree: what then
    int max_minority_rounds = 3;            // rounds in a row in the minority before the kick (0: never)
};

// Per slot, for tests, the log and reports.
struct SlotCounters {
    std::uint64_t inputs = 0;           // own inputs accepted
    std::uint64_t replaced = 0;         // frames confirmed with its input replaced
    std::uint64_t late = 0;             // inputs that arrived after their frame was confirmed
    std::uint64_t out_of_window = 0;    // inputs for frames too far ahead
    std::uint64_t desyncs = 0;          // times it was in the checksum minority (never reset)
    std::uint32_t minority_streak = 0;  // decided rounds in a row in the minority of a strict majority
};

class RelayRoom {
public:
    enum class SlotState : std::uint8_t { Absent, Running, Left };
    static constexpr std::uint8_t kNoSlot = 255;

    RelayRoom(std::uint64_t id, const rollback::RelayHello& first, const RoomConfig& config);

    std::uint64_t id() const { return id_; }
    bool matches(const rollback::RelayHello& h) const;
    // Binds c to a slot (or a spectator place) if the hello may have it; queues the welcome (or
    // the refusal) either way. Returns the refusal (None on success).
    // A held slot taken over from a silent connection names it in *replaced (to be closed).
    RelayRefusal admit(ConnectionId c, const rollback::RelayHello& h, std::uint64_t now_us, Outbox& out,
                       ConnectionId* replaced);
    // A bound connection said hello again (its welcome was lost): the same welcome again.
    void welcome_again(ConnectionId c, const rollback::RelayHello& h, std::uint64_t now_us, Outbox& out);
    // A bound connection's datagram. Returns nullptr, or why it was bad (the caller counts it).
    const char* receive(ConnectionId c, std::span<const std::uint8_t> d, std::uint64_t now_us, Outbox& out);
    // The connection is gone (closed, kicked or silent).
    void remove(ConnectionId c, std::uint64_t now_us);
    void tick(std::uint64_t now_us, Outbox& out);
    // Frames newly confirmed by receive() are broadcast by send_pending() (or the next tick()),
    // not at once: a pass that confirms several frames of a room (a backlog, both inputs of
    // two frames) then sends each client one Frames message carrying them all, not one per
    // frame. The caller calls send_pending() before it sends what the pass queued.
    bool frames_pending() const { return frames_pending_; }
    void send_pending(Outbox& out);
    void notify_all(const rollback::RelayNotice& n, Outbox& out);
    // Connections silent past silence_drop_us, for the server to remove.
    void silent_connections(std::uint64_t now_us, std::vector<ConnectionId>& out) const;

    bool started() const { return started_; }
    // When tick() next has work: the next room tick once started (tick() before it does nothing).
    std::uint64_t next_tick_us() const { return next_tick_us_; }
    bool empty() const;  // no connection left
    std::uint32_t clock_frame(std::uint64_t now_us) const;
    std::uint32_t confirmed_frames() const { return confirmed_next_; }  // frames [0, this) confirmed
    int players() const { return players_; }
    int tick_rate() const { return tick_rate_; }
    SlotState slot_state(int slot) const { return slots_[static_cast<std::size_t>(slot)].state; }
    const SlotCounters& slot_counters(int slot) const { return slots_[static_cast<std::size_t>(slot)].counters; }
    // Its id in the room: a slot (< players; the lowest it plays), players + place for a
    // spectator, -1 if not here.
    int slot_of(ConnectionId c) const;
    // The slots connection c plays, bit per slot (0: none, or a spectator).
    std::uint16_t connection_slots(ConnectionId c) const;
    // The connection holding player slot s; false when nobody does.
    bool holder(int slot, ConnectionId& c) const;
    // Connection c is here and was heard within replace_silent_us: nobody may take its place.
    bool live(ConnectionId c, std::uint64_t now_us) const;
    std::size_t history_frames() const { return history_.size(); }
    // Verdicts so far: (frame, odd slot).
    const std::vector<std::pair<std::uint32_t, int>>& desync_verdicts() const { return verdicts_; }
    // A round of two disagreeing voters ended the match (TwoPlayerDesync::EndMatch).
    bool ended_without_majority() const { return ended_without_majority_; }
    // Connections in the minority max_minority_rounds in a row since the last call, to kick.
    void take_kicks(std::vector<ConnectionId>& out);
    bool has_kicks() const { return !kicks_.empty(); }
    // The confirmed input set of a frame still in the history: flags then inputs.
    bool confirmed_inputs(std::uint32_t frame, std::vector<std::uint8_t>& flags, std::vector<std::uint8_t>& inputs) const;

private:
    struct Client {
        ConnectionId connection = 0;
        std::uint32_t ack = 0;             // next confirmed frame it needs
        std::uint64_t last_heard_us = 0;
        std::uint64_t last_send_us = 0;
        std::uint16_t stamp = 0;           // its last stamp, and when we got it
        std::uint64_t stamp_at_us = 0;
        bool has_stamp = false;
    };
    struct Slot {
        SlotState state = SlotState::Absent;
        Client client;
        bool connected = false;
        // While connected: the lowest slot of its connection, whose `client` speaks for them
        // all (acks, stamps, silence, sends); a slot's own `client` then only names the
        // connection.
        std::uint8_t primary = kNoSlot;
        bool late = false;                 // bound after the start: begins from a snapshot
        std::uint64_t incarnation = 0;
        std::uint32_t input_from = 0;      // its own inputs count from this frame
        // Bound to a running room (a join, a takeover, a return) and no input of its own at or
        // after input_from taken yet: its handoff has not started.
        bool awaiting_handoff = false;
        // Its handoff did not start within silence_drop_us of input_from: it plays the absent
        // input until its first input comes (which re-hands it from that frame).
        bool lapsed = false;
        std::vector<std::uint8_t> last_input;
        std::vector<std::uint8_t> pending;  // ring of kWindow inputs
        std::vector<std::uint32_t> pending_frame;  // frame held in each ring entry (+1; 0 = none)
        SlotCounters counters;
    };
    struct Spectator {
        Client client;
        bool connected = false;
        bool late = false;
    };
    struct Check {
        std::uint32_t frame = 0;
        std::array<std::uint64_t, rollback::kRelayMaxPlayers> value{};
        std::uint32_t have = 0;            // bit per slot
    };

    Client* client(int id);  // by slot_of() id (any slot: its connection's); nullptr when nobody is connected there
    bool is_primary(int slot) const {
        const Slot& s = slots_[static_cast<std::size_t>(slot)];
        return s.connected && s.primary == slot;
    }
    std::uint16_t slots_of(int primary) const;  // bit per slot whose primary this is
    void release(Slot& s);                       // unbinds one slot of a connection that left
    std::uint32_t connection_input_ack(int primary) const;
    void start(std::uint64_t now_us);
    void send_welcome(ConnectionId c, int id, RelayRefusal r, std::uint64_t echo_us, std::uint64_t now_us,
                      Outbox& out);
    bool id_joined_late(int id) const;
    // Slot s plays no input of its own at frame f (absent: nobody plays it, not yet, or lapsed).
    bool plays_absent(const Slot& s, std::uint32_t f) const {
        return s.state != SlotState::Running || f < s.input_from || s.lapsed;
    }
    void lapse_handoffs(std::uint64_t now_us);
    bool has_input(const Slot& s, std::uint32_t frame) const;
    const std::uint8_t* input_at(const Slot& s, std::uint32_t frame) const;
    std::uint32_t input_ack(const Slot& s) const;
    void confirm_ready(std::uint64_t now_us);
    void confirm_one(std::uint64_t now_us);
    void send_frames(Client& cl, std::uint32_t input_ack, std::uint64_t now_us, Outbox& out);
    void broadcast(std::uint64_t now_us, bool only_if_due, Outbox& out);
    void report_checksum(int slot, std::uint32_t frame, std::uint64_t value, std::uint64_t now_us, Outbox& out);
    void decide(Check& c, Outbox& out);
    int snapshot_source(int except) const;
    std::uint32_t history_base() const { return confirmed_next_ - static_cast<std::uint32_t>(history_.size()); }
public:
    // Bytes this room holds beyond its fixed part (history, input windows): what one room costs.
    std::size_t bytes_reserved() const;

private:

    std::uint64_t id_;
    RoomConfig config_;
    int players_;
    std::size_t input_size_;
    int tick_rate_;
    std::uint64_t scene_checksum_;
    std::uint16_t absent_at_start_;
    std::uint64_t period_us_;
    std::uint32_t max_frames_;  // frames one Frames message holds
    bool started_ = false;
    std::uint64_t start_us_ = 0;
    std::uint64_t next_tick_us_ = 0;
    std::uint32_t confirmed_next_ = 0;
    bool frames_pending_ = false;        // confirmed frames not broadcast yet (send_pending)
    std::uint64_t pending_now_us_ = 0;   // when they were confirmed: the Frames' clock stamp
    // Confirmed frames, oldest first: players flags then players * input_size inputs each.
    FrameHistory history_;
    std::vector<Slot> slots_;
    std::vector<Spectator> spectators_;
    static constexpr std::size_t kMaxPendingChecks = 16;
    std::deque<Check> checks_;
    std::deque<std::uint32_t> decided_;  // frames of the latest decided rounds
    std::vector<std::pair<std::uint32_t, int>> verdicts_;
    bool ended_without_majority_ = false;
    std::vector<ConnectionId> kicks_;  // liars found by decide(), for take_kicks()
    std::uint16_t banned_ = 0;         // bit s: slot s was kicked as a liar; refused from then on
    // decode / encode scratch
    rollback::RelayInput in_;
    rollback::RelayForward fwd_;
    rollback::RelayFrames frames_;
};

}  // namespace lockroll::server
