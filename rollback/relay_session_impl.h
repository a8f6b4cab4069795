// RelaySessionImpl: the relay client's state machine behind rollback::RelaySession
// (relay_session.h), which forwards every call to it. Not installed: its members name the
// internals (Sync, the input queue, the server's link, the relay wire messages) that the
// installed relay_session.h must not include. The contract of every public call is
// relay_session.h's; the code is in relay_session.cpp. Tests that look inside include this
// header and reach it through RelaySession::impl().
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/events.h"
#include "rollback/input_queue.h"
#include "rollback/peer_link.h"
#include "rollback/predictor.h"
#include "rollback/relay_messages.h"
#include "rollback/relay_session.h"
#include "rollback/session.h"
#include "rollback/session_core.h"
#include "rollback/session_types.h"
#include "rollback/simulation.h"
#include "rollback/snapshot_transfer.h"
#include "rollback/sync.h"

namespace lockroll::rollback {

class RelaySessionImpl : public SessionCore {
public:
    // As Session's: simulation, observer and predictor outlive it, the simulation in its
    // initial state (nullptr: no observer / the repeat-last predictor). A bad config throws
    // std::invalid_argument.
    RelaySessionImpl(const RelaySessionConfig& config, Simulation& simulation, SessionObserver* observer = nullptr,
                     Predictor* predictor = nullptr);
    ~RelaySessionImpl();

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
    void set_last_frame(std::uint32_t frame) { last_frame_ = frame; }
    // Frames this client is behind its target (0 when on time or ahead).
    std::int32_t behind(std::uint64_t now_us) const;
    // The transport lost the server and connected again: say hello again. The server knows this
    // process by its incarnation and resumes it (same slot, stream and state; no snapshot).
    void transport_reconnected(std::uint64_t now_us);
    // next_event(), inject_fault(), phase(), failure(), frame(), confirmed_frame(),
    // input_delay(), stalled(), recoveries(), saved_state(), stats(): SessionCore's.

    const RelaySessionConfig& config() const { return config_; }
    // The slots this client plays, ascending (empty for a spectator), and the bytes advance()
    // takes: input_size per local slot, in that order (a spectator: one input_size, ignored).
    const std::vector<PlayerId>& local_slots() const { return local_slots_; }
    std::size_t local_input_size() const { return config_.input_size * std::max<std::size_t>(1, local_slots_.size()); }
    // The server holds this client's inputs of every frame before this.
    std::uint32_t server_input_ack() const { return server_ack_; }
    // The session failed because the server went silent (server_timeout_us): ServerLost.
    bool server_lost() const { return server_lost_; }
    // This client's id in the room (its slot, or players + place for a spectator).
    int room_id_slot() const { return my_id_; }
    std::uint64_t rtt_us() const { return link_.rtt_us(); }
    std::uint64_t jitter_us() const { return link_.rtt_var_us(); }
    const RelayStats& relay_stats() const { return relay_stats_; }
    // Checksum of a confirmed frame among the newest kConfirmedKept.
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const;
    static constexpr std::uint32_t kConfirmedKept = 4096;

private:
    class OwnPredictor;

    // The per-tick calls' bodies; the public ones turn anything thrown (the game's step / save /
    // load, an allocation) into a failed session with the reason: nothing per tick throws.
    void receive_impl(std::span<const std::uint8_t> datagram, std::uint64_t now_us);
    AdvanceResult advance_impl(std::span<const std::uint8_t> local_input, std::uint64_t now_us);
    void poll_impl(std::uint64_t now_us, std::vector<Datagram>& out);
    int catch_up_impl(std::uint64_t now_us, int max_frames);
    void handle_welcome(std::uint64_t now_us);
    void handle_frames(std::uint64_t now_us);
    void handle_forward(std::uint64_t now_us);
    void handle_notice(std::uint64_t now_us);
    void start_running(std::uint64_t now_us);
    void begin_transfer(std::uint8_t from, TransferReason reason, std::uint64_t now_us);
    void finish_transfer(std::uint64_t now_us);
    void confirm_frames();
    void add_own_input(std::span<const std::uint8_t> input);
    void send_forward(std::uint8_t to, const std::vector<std::uint8_t>& payload);
    void malformed(const char* why);
    // Estimated room clock now, in 1/65536 frames (nullopt before the first frames message).
    std::optional<std::int64_t> room_clock(std::uint64_t now_us) const;
    std::int64_t target_lead() const;
    void revise_input_delay(std::uint64_t now_us);

    RelaySessionConfig config_;
    std::vector<PlayerId> local_slots_;  // relay_local_slots(config_), ascending
    Simulation& sim_;
    std::unique_ptr<OwnPredictor> own_predictor_;
    RelayStats relay_stats_;
    InputQueue own_;                     // inputs this client made, from the server's ack on
    PeerLink link_;                      // the server: round trip, stamps
    std::vector<Datagram> pending_out_;
    int my_id_ = -1;
    std::uint32_t handoff_ = 0;
    std::uint32_t server_ack_ = 0;
    std::uint16_t checksum_interval_ = 0;
    std::uint64_t incarnation_ = 0;
    std::uint64_t last_hello_us_ = 0;
    bool hello_sent_ = false;
    bool welcomed_ = false;
    bool server_lost_ = false;  // failed on the server's silence (server_lost())
    std::uint64_t last_server_us_ = 0;  // the last datagram from the server (0: none yet)
    bool room_started_ = false;
    std::uint64_t started_us_ = 0;
    std::uint32_t last_frame_ = ~std::uint32_t{0};  // set_last_frame()
    std::uint64_t last_delay_revision_us_ = 0;
    // Room clock estimate: the largest (room clock - local clock) seen in a window of samples.
    std::deque<std::int64_t> clock_offsets_;
    std::optional<std::int64_t> clock_offset_;
    // slot flags of the newest confirmed frame (for Joined / Disconnected events)
    std::vector<std::uint8_t> slot_flags_;
    std::vector<bool> slot_seen_;
    // checksums to report, each sent kChecksumRepeats times
    struct Report {
        std::uint32_t frame;
        std::uint64_t checksum;
        int sends;
    };
    std::deque<Report> reports_;
    std::vector<std::uint64_t> confirmed_checksums_;  // ring, frame % kConfirmedKept
    std::vector<std::uint32_t> confirmed_frames_;
    // snapshot transfer, receiving side
    std::optional<std::uint8_t> transfer_from_;
    TransferReason transfer_reason_ = TransferReason::Join;
    std::unique_ptr<TransferReceiver> incoming_;
    std::uint64_t last_offer_request_us_ = 0;
    std::uint64_t transfer_progress_us_ = 0;  // when the transfer began, or last moved on
    std::uint32_t recover_after_ = 0;    // Desync notices for frames before this are stale
    // providing side
    TransferSender outgoing_{20'000'000};  // offers, each kept for this long (us)
    // decode scratch
    RelayWelcome welcome_;
    RelayFrames frames_;
    RelayForward forward_;
    RelayNotice notice_;
    SnapshotRequestMessage snap_req_;
    SnapshotOfferMessage snap_offer_;
    SnapshotChunkMessage snap_chunk_;
    std::vector<std::uint8_t> scratch_;
};

}  // namespace lockroll::rollback
