// SessionImpl: the peer-to-peer session's state machine behind rollback::Session (session.h),
// which forwards every call to it. Not installed: its members name the internals (Sync, the
// peer links, membership, the wire messages) that the installed session.h must not include.
// The contract of every public call is session.h's; the code is in session.cpp. In-tree code
// and tests that look inside a session (membership(), the links) include this header and reach
// it through Session::impl().
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/authored_streams.h"
#include "rollback/confirm_floors.h"
#include "rollback/control_messages.h"
#include "rollback/desync_detector.h"
#include "rollback/events.h"
#include "rollback/frame_pacing.h"
#include "rollback/handshake.h"
#include "rollback/input_intake.h"
#include "rollback/joiner_reach.h"
#include "rollback/membership.h"
#include "rollback/membership_changes.h"
#include "rollback/peer_link.h"
#include "rollback/predictor.h"
#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/session_core.h"
#include "rollback/session_types.h"
#include "rollback/simulation.h"
#include "rollback/slot_hosts.h"
#include "rollback/slot_view.h"
#include "rollback/snapshot_fetch.h"
#include "rollback/snapshot_server.h"
#include "rollback/snapshot_transfer.h"
#include "rollback/stream_relay.h"
#include "rollback/sync.h"

namespace lockroll::rollback {

class InputAuthority;   // rollback/input_authority.h

class SessionImpl : public SessionCore {
public:
    // The simulation must be in its initial state and outlive the session, as must the
    // observer and predictor (nullptr: none / repeat-last). Throws std::invalid_argument for a
    // bad config.
    SessionImpl(const SessionConfig& config, Simulation& simulation, SessionObserver* observer = nullptr,
                Predictor* predictor = nullptr);
    ~SessionImpl();

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
    int prediction_window() const { return sync_->prediction_window(); }
    // Drops a slot on purpose (a kick): as if it had been silent for disconnect_us.
    void disconnect_player(PlayerId slot, std::uint64_t now_us) { changes_.disconnect_player(slot, now_us); }
    // A joiner that loaded a snapshot is behind the match: step up to max_frames without taking
    // input (call after advance() while behind() > 0). Returns the frames stepped.
    int catch_up(std::uint64_t now_us, int max_frames) noexcept;
    // The last frame this session simulates (a run of N frames ends on frame N, not beyond):
    // once frame() reaches it, advance() and catch_up() still take inputs, roll back and confirm,
    // but step no further, and a held tick is not a stall. Default: no limit.
    void set_last_frame(std::uint32_t frame) { last_frame_ = frame; }
    // Frames the most advanced running peer is estimated to be ahead of this session.
    std::int32_t behind(std::uint64_t now_us) const;
    // next_event(), inject_fault(): SessionCore's (rollback/session_core.h).
    // Fault injection (a test hook; `lockroll peer --corrupt-snapshot / --truncate-snapshot`):
    // the next `count` snapshot chunks this session sends, as provider of a join, spectate or
    // recovery transfer, are damaged as `how` says, after any still pending. Its own state and
    // the blob it keeps stay intact, so a chunk asked for again goes out whole once the count is
    // used up. damaged_chunks() counts the chunks damaged so far.
    void damage_outgoing_chunks(int count, ChunkDamage how);
    std::uint64_t damaged_chunks() const { return server_.damaged_chunks(); }

    const SessionConfig& config() const { return config_; }
    // The slots this session plays, ascending: local_player first, then the slots it hosts
    // (config.slot_hosts). Empty for a spectator. advance() takes one input per entry.
    std::span<const PlayerId> local_slots() const { return local_slots_; }
    // The slot whose process plays `slot` (itself unless config.slot_hosts says otherwise).
    PlayerId host_of(PlayerId slot) const { return lockroll::rollback::host_of(config_, slot); }
    SlotState slot_state(PlayerId slot) const { return membership_.state(slot); }
    // The view and the votes (who plays, who says whom is gone).
    const Membership& membership() const { return membership_; }
    // Reported Partitioned and not yet heard a majority again.
    bool partitioned() const { return changes_.partitioned(); }
    // Silent longer than interrupt_us (and not dropped yet).
    bool interrupted(PlayerId peer) const { return links_[peer].interrupted; }
    std::uint64_t foreign_packets() const { return foreign_packets_; }  // other match or version
    // phase(), failure(), frame(), confirmed_frame(), input_delay(), stalled(), recoveries(),
    // saved_state(), stats(): SessionCore's.
    // Checksum of a confirmed frame, while remembered.
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const {
        return detector_->local_checksum(frame);
    }
    // stats().peers[p].rtt_us / frame_advantage_x100 are refreshed by advance().
    bool peer_error(PlayerId p) const { return links_[p].error(); }
    // Smoothed round trip to a peer (µs; 0 until measured).
    std::uint64_t rtt_us(PlayerId p) const { return links_[p].rtt_us(); }
    // The first of our input frames peer p has not acknowledged: p holds our inputs of every
    // frame before it (so once it is > n and p has everyone else's, p can confirm frame n + 1).
    std::uint32_t peer_ack(PlayerId p) const { return links_[p].remote_ack; }
    // Ping, jitter, bandwidth, frames behind and send queue of one peer, for an overlay.
    NetworkStats network_stats(PlayerId p, std::uint64_t now_us) const;
    bool desynced(PlayerId p) const { return detector_->desynced(p); }
    // Frames this client is ahead of the slowest peer (x100), averaged over the window.
    std::int32_t frames_ahead_x100() const;
    // The scene checksum its hellos carry (config.scene_checksum, else the initial state's).
    std::uint64_t scene_checksum() const { return scene_checksum_; }
    // A session started again as a joiner after a drop goes on from the one it replaces: its
    // counters, last frame and prediction window (rollback/rejoin.h; the code is rejoin.cpp).
    void continue_from(const SessionImpl& before);

private:
    class Tap;  // sees the detector's and sync's callbacks first, then forwards them
    void receive_impl(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us);
    AdvanceResult advance_impl(std::span<const std::uint8_t> local_input, std::uint64_t now_us);
    void poll_impl(std::uint64_t now_us, std::vector<Datagram>& out);
    int catch_up_impl(std::uint64_t now_us, int max_frames);
    IntakeState intake_state();
    std::uint32_t lead_frames(std::uint64_t rtt_us) const;
    // A live player peer: its pace counts for time sync (pacing_).
    bool paces(PlayerId p) const;
    FramePacing::Paces pacer() const { return [this](PlayerId p) { return paces(p); }; }
    void handle_hello(PlayerId from, const HelloMessage& m, std::uint64_t now_us);
    void handle_welcome(PlayerId from, const WelcomeMessage& m, std::uint64_t now_us);
    void handle_snapshot_request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us);
    void handle_snapshot_offer(PlayerId from, const SnapshotOfferMessage& m, std::uint64_t now_us);
    void handle_snapshot_chunk(PlayerId from, const SnapshotChunkMessage& m, std::uint64_t now_us);
    void malformed(PlayerId from, const char* why);
    void confirm_frames();
    std::uint32_t confirm_limit() const;
    void sample_time_sync(std::uint64_t now_us);
    void refresh_resend_floor();
    void refresh_keep_floors(std::uint64_t now_us);
    void cut_loose_lagging_spectators(std::uint64_t now_us);
    std::uint32_t checkpoint() const;
    void send_control(PlayerId to, std::vector<std::uint8_t> bytes);
    void poll_handshake(std::uint64_t now_us);
    void poll_transfer(std::uint64_t now_us);
    void start_running(std::uint64_t now_us);
    void maybe_start(std::uint64_t now_us);
    void finish_transfer(std::uint64_t now_us);
    void consider_recovery(std::uint64_t now_us);
    // The slot table and relays on the wire (rollback/stream_relay.h) read the session through this.
    StreamView stream_view() const;
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(config_.players); }
    // A slot played by another slot's process: no peer id, no link of its own.
    bool is_guest(PlayerId p) const { return host_of(p) != p; }
    // A guest slot whose stream this session authors.
    bool my_guest(PlayerId p) const {
        return config_.role != Role::Spectator && is_guest(p) && host_of(p) == config_.local_player;
    }
    bool slot_running(PlayerId s) const { return membership_.running(s); }
    // A peer whose traffic matters now: welcomed, not in error, and a running slot or spectator.
    bool live_peer(PlayerId p) const;
    LivePeer live() const { return [this](PlayerId p) { return live_peer(p); }; }
    std::uint32_t count_of(PlayerId slot) const { return sync_->queue(slot).confirmed_count(); }
    int peers_total() const { return config_.players + config_.max_spectators; }
    std::uint32_t local_target() const;

    SessionConfig config_;
    Simulation& sim_;
    std::unique_ptr<DesyncDetector> detector_;
    std::vector<PeerLink> links_;
    std::vector<std::int32_t> local_advantage_;   // per peer, latest estimate (frames)
    std::vector<int> replies_this_poll_;
    std::vector<Datagram> pending_out_;
    // decode scratch, reused
    InputMessage in_msg_;
    QueryMessage query_msg_;
    ReplyMessage reply_msg_;
    InputMessage out_msg_;
    std::vector<std::uint16_t> table_entries_;  // our table's entries to one peer (poll scratch)
    std::vector<std::pair<PlayerId, QueryMessage>> queries_;

    // lifecycle
    std::unique_ptr<Tap> tap_;
    Membership membership_;
    std::vector<SlotView> slots_;
    std::vector<PlayerId> local_slots_;
    // What the session does about the view, and the streams it writes besides its own (after the
    // state they borrow); Effects (rollback/session_effects.h) is the rest of the session as they,
    // InputIntake and JoinHandoff see it.
    class Effects;
    std::unique_ptr<Effects> effects_;
    MembershipChanges changes_;
    AuthoredStreams authored_;
    std::uint64_t foreign_packets_ = 0;
    std::uint64_t scene_checksum_ = 0;
    std::uint64_t started_us_ = 0;
    std::uint64_t last_now_us_ = 0;
    std::uint32_t last_frame_ = ~std::uint32_t{0};  // set_last_frame()
    // the newcomer's (or a recovering peer's) side of a transfer
    SnapshotFetch fetch_;
    JoinerReach reach_;  // a joiner's until it loads, a restarted player's: cut off from a majority (rollback/joiner_reach.h)
    FramePacing pacing_;  // declared after config_, which it reads
    Handshake handshake_;  // after config_ and membership_
    std::optional<PlayerId> recover_from_;
    SessionEvent::Reason recovery_reason_ = SessionEvent::Reason::None;  // Majority or TieRule, with:
    std::string recovery_why_;  // why this peer reloads from recover_from_: "in the minority at frame F, by RULE"
    bool joining_ = false;          // local stream starts ahead of the shown frame
    // A joiner's handoff frame. Its stream before it is the owner's neutral input, flagged
    // absent, which every peer holds or gets from the owner: never sent as its own (it differed
    // in that flag, a malformed message at every peer whose link to it was new: one per join,
    // and with several joining at once, max_bad_packets, after which the joiner was ignored).
    std::uint32_t own_inputs_from_ = 0;
    // the provider's side
    SnapshotServer server_;
    // desync recovery
    std::optional<std::uint32_t> mismatch_frame_;
    std::uint64_t mismatch_since_us_ = 0;
    HelloMessage hello_msg_;
    WelcomeMessage welcome_msg_;
    SnapshotRequestMessage snap_req_msg_;
    SnapshotOfferMessage snap_offer_msg_;
    SnapshotChunkMessage snap_chunk_msg_;
    // Relayed inputs only fill gaps (rollback/input_authority.h): who wrote each running slot's
    // unverified inputs; the owner's own copy settles them (rollback/input_intake.h).
    std::unique_ptr<InputAuthority> authority_;
};

}  // namespace lockroll::rollback
