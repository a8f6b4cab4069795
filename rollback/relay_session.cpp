#include "rollback/relay_session_impl.h"

#include "rollback/input_delay.h"
#include "rollback/time_sync.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace lockroll::rollback {

namespace {
constexpr int kChecksumRepeats = 3;
constexpr std::size_t kMaxReports = 8;
constexpr std::size_t kClockSamples = 32;
constexpr std::uint64_t kDelayRevisionUs = 2'000'000;
constexpr std::int64_t kFrac = 65536;  // room clock units per frame
}  // namespace

// The local slot's guess is the input this client sent for that frame; everyone else's is the
// game's predictor's.
class RelaySessionImpl::OwnPredictor final : public Predictor {
public:
    OwnPredictor(RelaySessionImpl& s, Predictor& inner) : s_(s), inner_(inner) {}
    void predict(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> last_confirmed,
                 std::uint32_t last_confirmed_frame, std::span<std::uint8_t> out) override {
        const InputQueue& own = s_.own_;
        const auto& mine = s_.local_slots_;
        const auto at = std::find(mine.begin(), mine.end(), player);
        if (at != mine.end() && frame >= own.floor() && frame < own.confirmed_count()) {
            // own_ holds one record per frame: every local slot's input, in slot order.
            const auto in = own.confirmed(frame).subspan(static_cast<std::size_t>(at - mine.begin()) * out.size(), out.size());
            std::copy(in.begin(), in.end(), out.begin());
            return;
        }
        inner_.predict(player, frame, last_confirmed, last_confirmed_frame, out);
    }

private:
    RelaySessionImpl& s_;
    Predictor& inner_;
};

void validate(const RelaySessionConfig& c) {
    auto need = [](bool ok, const char* what) {
        if (!ok) throw std::invalid_argument(what);
    };
    need(c.players >= 1 && c.players <= kRelayMaxPlayers, "relay session: players must be 1..16");
    need(c.role == RelayRole::Spectator || c.local_slot < static_cast<PlayerId>(c.players), "relay session: local slot out of range");
    need(c.input_size >= 1 && c.input_size <= kRelayMaxInputSize, "relay session: input size must be 1..64");
    need(c.tick_rate >= 1 && c.tick_rate <= 1000, "relay session: tick rate must be 1..1000");
    need(c.input_delay >= 0 && c.input_delay <= 60, "relay session: input delay must be 0..60");
    need(c.prediction_window >= 0 && c.prediction_window <= 120, "relay session: prediction window must be 0..120");
    need(c.transfer_window >= 1 && c.transfer_window <= 256, "relay session: transfer window must be 1..256");
    need(c.max_recoveries >= 0, "relay session: max recoveries must be >= 0");
    need(c.hello_resend_us > 0 && c.transfer_resend_us > 0, "relay session: resend intervals must be positive");
    need(c.connect_token.size() <= kRelayMaxTokenBytes, "relay session: connect token longer than 256 bytes");
    need(c.role != RelayRole::Spectator || c.also_slots == 0, "relay session: a spectator plays no slot (also_slots must be 0)");
    need(c.role == RelayRole::Spectator || c.local_slot >= static_cast<PlayerId>(c.players) ||
             (c.also_slots >> c.players) == 0,
         "relay session: also_slots names a slot out of range");
    need(c.role == RelayRole::Spectator || c.local_slot >= static_cast<PlayerId>(c.players) ||
             (c.also_slots & ((2u << c.local_slot) - 1)) == 0,
         "relay session: also_slots must be above local_slot (the lowest local slot)");
}

std::uint16_t relay_local_slots(const RelaySessionConfig& c) {
    if (c.role == RelayRole::Spectator || c.local_slot >= kRelayMaxPlayers) return 0;
    return static_cast<std::uint16_t>(c.also_slots | (1u << c.local_slot));
}

namespace {
// The Refused (and Failed) event's reason for the server's refusal of our hello.
SessionEvent::Reason refusal_reason(RelayRefusal r) {
    using R = SessionEvent::Reason;
    switch (r) {
        case RelayRefusal::None: return R::None;
        case RelayRefusal::Version: return R::Version;
        case RelayRefusal::RoomParams: return R::RoomParams;
        case RelayRefusal::SlotTaken: return R::SlotTaken;
        case RelayRefusal::BadSlot: return R::BadSlot;
        case RelayRefusal::Full: return R::Full;
        case RelayRefusal::Draining: return R::ServerDraining;
        case RelayRefusal::Spoof: return R::Spoof;
        case RelayRefusal::Ended: return R::MatchEnded;
        case RelayRefusal::TokenMissing: return R::TokenMissing;
        case RelayRefusal::TokenInvalid: return R::TokenInvalid;
        case RelayRefusal::TokenExpired: return R::TokenExpired;
        case RelayRefusal::TokenMismatch: return R::TokenMismatch;
        case RelayRefusal::TokenInUse: return R::TokenInUse;
        case RelayRefusal::SlotOwned: return R::SlotOwned;
        case RelayRefusal::Kicked: return R::KickedByServer;
    }
    return R::None;
}

std::vector<PlayerId> slot_list(std::uint16_t mask) {
    std::vector<PlayerId> out;
    for (int s = 0; s < kRelayMaxPlayers; ++s)
        if (mask & (1u << s)) out.push_back(static_cast<PlayerId>(s));
    return out;
}
}  // namespace

RelaySessionImpl::RelaySessionImpl(const RelaySessionConfig& config, Simulation& simulation, SessionObserver* observer,
                           Predictor* predictor)
    : SessionCore(SessionPhase::Synchronizing, config.local_slot, config.input_delay, observer),
      config_(config),
      local_slots_(slot_list(relay_local_slots(config))),
      sim_(simulation),
      own_(config.input_size * std::max<std::size_t>(1, local_slots_.size()), config.input_capacity),
      link_(1, 60) {
    validate(config_);
    default_to_zero(config_.cpu_clock);
    own_predictor_ = std::make_unique<OwnPredictor>(*this, predictor_or_default(predictor));
    SyncConfig sc = sync_config(config_.players, config_.role == RelayRole::Spectator ? 0 : config_.local_slot, config_.input_size,
                                config_.prediction_window, config_.evidence_frames, config_.input_capacity);
    sc.all_streams_remote = true;
    stats_.peers.resize(static_cast<std::size_t>(config_.players));
    sync_ = std::make_unique<Sync>(sc, sim_, *own_predictor_, observer_, stats_, config_.cpu_clock);
    if (config_.scene_checksum == 0) config_.scene_checksum = sync_->initial_checksum();
    slot_flags_.assign(static_cast<std::size_t>(config_.players), kRelayAbsent);
    slot_seen_.assign(static_cast<std::size_t>(config_.players), false);
    input_delay_ = std::clamp(input_delay_, 0, static_cast<int>(config_.input_capacity / 4));
    confirmed_checksums_.assign(kConfirmedKept, 0);
    confirmed_frames_.assign(kConfirmedKept, 0);
}

std::optional<std::uint64_t> RelaySessionImpl::confirmed_checksum(std::uint32_t frame) const {
    if (frame == 0 || frame > sync_->confirmed_frame() || confirmed_frames_[frame % kConfirmedKept] != frame) return std::nullopt;
    return confirmed_checksums_[frame % kConfirmedKept];
}

RelaySessionImpl::~RelaySessionImpl() = default;

void RelaySessionImpl::malformed(const char* why) {
    ++stats_.malformed_packets;
    link_.note_malformed(why);
}

// ---- receiving ----

void RelaySessionImpl::receive_impl(std::span<const std::uint8_t> d, std::uint64_t now_us) {
    if (!incarnation_) incarnation_ = config_.incarnation ? config_.incarnation : now_us | 1;
    ++stats_.packets_received;
    stats_.bytes_received += d.size();
    if (phase_ == SessionPhase::Failed) return;
    last_server_us_ = std::max(last_server_us_, now_us);
    const auto kind = peek_relay_kind(d);
    if (!kind) return malformed("relay: unknown message kind");
    const char* err = nullptr;
    switch (*kind) {
        case RelayKind::Welcome:
            if (!(err = decode(d, welcome_))) handle_welcome(now_us);
            break;
        case RelayKind::Frames:
            if (!(err = decode(d, config_.players, config_.input_size, frames_))) handle_frames(now_us);
            break;
        case RelayKind::Forward:
            if (!(err = decode(d, forward_))) handle_forward(now_us);
            break;
        case RelayKind::Notice:
            if (!(err = decode(d, notice_))) handle_notice(now_us);
            break;
        default: err = "relay: a client's message kind from the server";
    }
    if (err) malformed(err);
}

void RelaySessionImpl::handle_welcome(std::uint64_t now_us) {
    const RelayWelcome& w = welcome_;
    if (welcomed_) return;  // a repeat
    if (w.refusal != RelayRefusal::None) {
        const std::string why = std::string("relay server refused: ") + relay_refusal_name(w.refusal);
        emit(SessionEvent::Kind::Refused, refusal_reason(w.refusal), config_.local_slot, 0, now_us, why);
        return fail(refusal_reason(w.refusal), why, now_us);
    }
    if (w.players != config_.players || w.input_size != config_.input_size || w.tick_rate != config_.tick_rate)
        return fail(SessionEvent::Reason::RoomMismatch, "relay server: the room's players, input size or tick rate differ", now_us);
    if (phase_ == SessionPhase::Running || phase_ == SessionPhase::Transferring) {
        // Welcomed again after a reconnect. A room this client played in has started, and its
        // clock runs on where this client's estimate of it says; a room that has not started,
        // or whose clock is far behind that estimate, is a new room (the server restarted). The
        // match is gone there, and resuming would only get this client kicked for frames the
        // room never confirmed, again on every reconnect.
        const std::int64_t expected = room_clock(now_us).value_or(0) / kFrac;
        const auto slack = static_cast<std::int64_t>(config_.tick_rate) +
                           static_cast<std::int64_t>(link_.rtt_us() * static_cast<std::uint64_t>(config_.tick_rate) / 1000000);
        if (!w.started || std::int64_t{w.server_frame} + slack < expected)
            return fail(SessionEvent::Reason::RoomRestarted,
                        "relay server: the room restarted (its clock at frame " + std::to_string(w.server_frame) +
                            ", expected about " + std::to_string(expected) + "): the match cannot resume",
                        now_us);
        welcomed_ = true;
        emit(SessionEvent::Kind::Resumed, SessionEvent::Reason::Reconnected, static_cast<PlayerId>(w.slot), frame(), now_us, "resumed on a new connection");
        return;
    }
    welcomed_ = true;
    my_id_ = w.slot;
    checksum_interval_ = w.checksum_interval;
    // No round trip from the hello's echo: the hello may have waited for the connection (a
    // runner holds reliable sends until it is up). Frames messages echo input stamps instead.
    emit(SessionEvent::Kind::Synchronizing, SessionEvent::Reason::RelayWelcome, static_cast<PlayerId>(my_id_), 0, now_us,
         "welcomed by the relay server as id " + std::to_string(my_id_));
    room_started_ = w.started;
    handoff_ = w.handoff_frame;
    if (w.started && w.snapshot_from != RelayWelcome{}.snapshot_from) {
        const auto reason = config_.role == RelayRole::Spectator ? TransferReason::Spectate : TransferReason::Join;
        begin_transfer(w.snapshot_from, reason, now_us);
    } else if (w.started) {
        start_running(now_us);
    }
}

void RelaySessionImpl::start_running(std::uint64_t now_us) {
    if (phase_ == SessionPhase::Running) return;
    phase_ = SessionPhase::Running;
    started_us_ = now_us;
    emit(SessionEvent::Kind::Synchronized, SessionEvent::Reason::Handshake, static_cast<PlayerId>(std::max(my_id_, 0)), frame(),
         now_us,
         "input delay " + std::to_string(input_delay_) + ", rtt " + std::to_string(link_.rtt_us() / 1000) + " ms");
}

void RelaySessionImpl::handle_frames(std::uint64_t now_us) {
    const RelayFrames& m = frames_;
    if (!welcomed_) return;
    // Round trip from the echoed stamp, then the room clock sample (the freshest of a window wins:
    // a delayed datagram only ever makes the clock look older).
    link_.take_stamps(m.stamp, m.echo, m.hold, now_us);
    const std::int64_t room = static_cast<std::int64_t>(m.server_frame) * kFrac + m.server_subframe;
    const std::int64_t half_rtt = static_cast<std::int64_t>(link_.rtt_us() / 2 * static_cast<std::uint64_t>(config_.tick_rate)) * kFrac / 1000000;
    const std::int64_t local = static_cast<std::int64_t>(now_us) * config_.tick_rate / 1000000 * kFrac +
                               static_cast<std::int64_t>(now_us * static_cast<std::uint64_t>(config_.tick_rate) % 1000000) * kFrac / 1000000;
    clock_offsets_.push_back(room + half_rtt - local);
    if (clock_offsets_.size() > kClockSamples) clock_offsets_.pop_front();
    clock_offset_ = *std::max_element(clock_offsets_.begin(), clock_offsets_.end());
    server_ack_ = std::max(server_ack_, m.input_ack);
    room_started_ = true;
    if (phase_ == SessionPhase::Synchronizing && !transfer_from_) start_running(now_us);
    if (phase_ != SessionPhase::Running) return;

    const std::uint32_t before = sync_->inputs_complete();
    const std::size_t slots = static_cast<std::size_t>(config_.players);
    const std::size_t n = config_.input_size;
    for (std::uint32_t i = 0; i < m.frame_count; ++i) {
        const std::uint32_t f = m.first_frame + i;
        for (std::size_t p = 0; p < slots; ++p) {
            const std::uint8_t flags = m.flags[i * slots + p];
            const auto input = std::span<const std::uint8_t>(m.inputs).subspan((i * slots + p) * n, n);
            if (sync_->add_remote_input(static_cast<PlayerId>(p), f, input, (flags & kRelayAbsent) != 0) !=
                InputQueue::Add::Stored)
                continue;
            if (flags & kRelayReplaced) {
                ++relay_stats_.replaced_any;
                if (relay_local_slots(config_) & (1u << p)) ++relay_stats_.own_replaced;
            }
            const bool absent = flags & kRelayAbsent;
            const bool was_absent = slot_flags_[p] & kRelayAbsent;
            if (slot_seen_[p] && absent != was_absent)
                emit(absent ? SessionEvent::Kind::Disconnected : SessionEvent::Kind::Joined,
                     absent ? SessionEvent::Reason::ServerInputAbsent : SessionEvent::Reason::ServerInputsStart, static_cast<PlayerId>(p), f,
                     now_us, absent ? "its input is absent from here (the server)" : "its inputs start here");
            slot_flags_[p] = flags;
            slot_seen_[p] = true;
        }
    }
    relay_stats_.frames_received += sync_->inputs_complete() - before;
}

void RelaySessionImpl::send_forward(std::uint8_t to, const std::vector<std::uint8_t>& payload) {
    RelayForward f;
    f.slot = to;
    f.payload = payload;
    Datagram d{kRelayServerPeer, {}, true};
    encode(f, d.bytes);
    pending_out_.push_back(std::move(d));
}

void RelaySessionImpl::handle_forward(std::uint64_t now_us) {
    const std::uint8_t from = forward_.slot;
    const auto payload = std::span<const std::uint8_t>(forward_.payload);
    const auto kind = peek_kind(payload);
    if (kind == MessageKind::SnapshotRequest) {
        if (const char* e = decode(payload, snap_req_)) return malformed(e);
        if (snap_req_.transfer_id == 0) {
            // Offer the newest confirmed frame (every peer that plays holds it).
            if (phase_ != SessionPhase::Running) return;
            TransferContents t;
            if (!sync_->transfer_contents(sync_->confirmed_frame(), false, t)) return;
            const TransferSender::Transfer& o = outgoing_.offer(from, snap_req_.reason, t, config_.input_size, now_us);
            scratch_.clear();
            encode(o.offer, scratch_);
            send_forward(from, scratch_);
            return;
        }
        if (const TransferSender::Transfer* o = outgoing_.find(snap_req_.transfer_id, from)) {
            SnapshotChunkMessage c;
            if (!TransferSender::chunk(*o, snap_req_.chunk, c)) return malformed("snapshot request: chunk out of range");
            scratch_.clear();
            encode(c, scratch_);
            send_forward(from, scratch_);
            return;
        }
        return;  // an expired transfer: the requester asks for a new offer
    }
    if (!transfer_from_ || from != *transfer_from_) return;  // not the source we asked
    if (kind == MessageKind::SnapshotOffer) {
        if (const char* e = decode(payload, snap_offer_)) return malformed(e);
        if (incoming_ && incoming_->offer().transfer_id == snap_offer_.transfer_id) return;
        if (snap_offer_.size == 0 || snap_offer_.size > config_.max_snapshot_bytes) return malformed("snapshot offer: size out of range");
        incoming_ = std::make_unique<TransferReceiver>(snap_offer_);
        incoming_->started_us = now_us;
        transfer_progress_us_ = now_us;
        return;
    }
    if (kind == MessageKind::SnapshotChunk) {
        if (const char* e = decode(payload, snap_chunk_)) return malformed(e);
        if (!incoming_ || !incoming_->add(snap_chunk_)) return;
        transfer_progress_us_ = now_us;
        if (incoming_->complete()) finish_transfer(now_us);
        return;
    }
    malformed("relay forward: not a snapshot message");
}

void RelaySessionImpl::begin_transfer(std::uint8_t from, TransferReason reason, std::uint64_t now_us) {
    transfer_progress_us_ = now_us;
    phase_ = SessionPhase::Transferring;
    transfer_from_ = from;
    transfer_reason_ = reason;
    incoming_.reset();
    last_offer_request_us_ = 0;
}

void RelaySessionImpl::finish_transfer(std::uint64_t now_us) {
    const auto blob = incoming_->verified();
    TransferContents t;
    std::string err = blob ? unpack_transfer(*blob, sim_.state_size(), config_.players, config_.input_size,
                                             config_.input_capacity, t)
                           : "checksum of the assembled snapshot does not match the offer";
    if (err.empty()) err = sync_->restart_at(t.frame, t.state);
    incoming_.reset();
    if (!err.empty()) {
        emit(SessionEvent::Kind::SnapshotRejected, SessionEvent::Reason::TransferInvalid, *transfer_from_, 0, now_us, err);
        last_offer_request_us_ = 0;  // ask for a new offer at once
        return;
    }
    const std::uint8_t from = *transfer_from_;
    transfer_from_.reset();
    std::fill(slot_seen_.begin(), slot_seen_.end(), false);
    clock_offsets_.clear();  // paced afresh from the next frames message
    emit(SessionEvent::Kind::SnapshotLoaded,
         transfer_reason_ == TransferReason::Recover  ? SessionEvent::Reason::Recovering
         : transfer_reason_ == TransferReason::Spectate ? SessionEvent::Reason::Spectating
                                                        : SessionEvent::Reason::Joining,
         from, t.frame, now_us, "from id " + std::to_string(from));
    if (transfer_reason_ == TransferReason::Recover) {
        recover_after_ = t.frame + 1;
        phase_ = SessionPhase::Running;
        emit(SessionEvent::Kind::DesyncRecovered, SessionEvent::Reason::Majority, from, t.frame, now_us,
             "reloaded the majority's state");
        return;
    }
    if (config_.role != RelayRole::Spectator) {
        own_.restart_at(std::max(handoff_, t.frame));
        server_ack_ = std::max(server_ack_, std::max(handoff_, t.frame));
    }
    phase_ = SessionPhase::Synchronizing;
    start_running(now_us);
}

void RelaySessionImpl::handle_notice(std::uint64_t now_us) {
    const RelayNotice& n = notice_;
    switch (n.kind) {
        case RelayNoticeKind::Desync: {
            if (phase_ != SessionPhase::Running || n.frame < recover_after_) return;  // stale, or already reloading
            ++relay_stats_.desync_notices;
            ++stats_.desyncs;
            const bool no_majority = n.slot == kRelayNoMajority;
            emit(SessionEvent::Kind::DesyncDetected, no_majority ? SessionEvent::Reason::ServerNoMajority : SessionEvent::Reason::ServerMinority,
                 static_cast<PlayerId>(std::max(my_id_, 0)), n.frame, now_us,
                 no_majority ? "the relay server found the two players' checksums of frame " + std::to_string(n.frame) +
                                   " differ, with no majority to settle it"
                             : "the relay server found this client's checksum of frame " + std::to_string(n.frame) +
                                   " in the minority; reloading from slot " + std::to_string(n.slot));
            if (observer_) observer_->on_desync({static_cast<PlayerId>(n.slot), n.frame, 0, n.detail});
            // The server's two-player rule (docs/relay.md): neither can be shown wrong, the match
            // ends for both; a reload from the other could be a reload from a liar, for ever.
            if (no_majority)
                return fail(SessionEvent::Reason::ServerNoMajority,
                            "desync at frame " + std::to_string(n.frame) +
                                ": two players disagree and no majority can settle it (the server's two-player rule "
                                "ends the match)",
                            now_us);
            if (recoveries_ >= config_.max_recoveries)
                return fail(SessionEvent::Reason::RecoveryLimit,
                            "desync at frame " + std::to_string(n.frame) + " (the server's verdict) and no recovery left", now_us);
            ++recoveries_;
            begin_transfer(n.slot, TransferReason::Recover, now_us);
            return;
        }
        case RelayNoticeKind::Snapshot:
            if (transfer_from_) begin_transfer(n.slot, transfer_reason_, now_us);
            return;
        case RelayNoticeKind::Draining:
            emit(SessionEvent::Kind::Draining, SessionEvent::Reason::ServerDraining, kRelayServerPeer, frame(), now_us, "the relay server is draining");
            return;
        case RelayNoticeKind::Kicked:
            emit(SessionEvent::Kind::Kicked, SessionEvent::Reason::KickedByServer, static_cast<PlayerId>(std::max(my_id_, 0)), frame(),
                 now_us, "kicked by the relay server");
            return fail(SessionEvent::Reason::KickedByServer, "kicked by the relay server", now_us);
    }
}

void RelaySessionImpl::transport_reconnected(std::uint64_t now_us) {
    (void)now_us;
    if (phase_ == SessionPhase::Failed || !welcomed_) return;
    welcomed_ = false;  // say hello again on the new connection (same incarnation: a resume)
    hello_sent_ = false;
}

// ---- pacing ----

std::optional<std::int64_t> RelaySessionImpl::room_clock(std::uint64_t now_us) const {
    if (!clock_offset_) return std::nullopt;
    const std::int64_t local = static_cast<std::int64_t>(now_us) * config_.tick_rate / 1000000 * kFrac +
                               static_cast<std::int64_t>(now_us * static_cast<std::uint64_t>(config_.tick_rate) % 1000000) * kFrac / 1000000;
    return local + *clock_offset_;
}

std::int64_t RelaySessionImpl::target_lead() const {
    const auto period = static_cast<std::int64_t>(1000000 / config_.tick_rate);
    const auto need = static_cast<std::int64_t>(link_.rtt_us() / 2 + 2 * link_.rtt_var_us());
    return (need + period - 1) / period + 1 - input_delay_;
}

std::int32_t RelaySessionImpl::behind(std::uint64_t now_us) const {
    if (phase_ != SessionPhase::Running) return 0;
    const auto clock = room_clock(now_us);
    if (!clock) return 0;
    const std::int64_t target = *clock / kFrac + target_lead();
    const std::int64_t gap = target - static_cast<std::int64_t>(frame());
    return gap >= 2 ? static_cast<std::int32_t>(std::min<std::int64_t>(gap - 1, 1 << 20)) : 0;
}

void RelaySessionImpl::revise_input_delay(std::uint64_t now_us) {
    if (!config_.auto_input_delay || config_.role == RelayRole::Spectator || !link_.has_rtt()) return;
    if (last_delay_revision_us_ && now_us - last_delay_revision_us_ < kDelayRevisionUs) return;
    // The one policy (rollback/input_delay.h): an input reaches the others through the server,
    // so across the whole round trip to it, plus twice its jitter.
    const int want = std::clamp(auto_input_delay(config_.prediction_window, link_.rtt_us() + 2 * link_.rtt_var_us(), config_.tick_rate),
                                0, static_cast<int>(config_.input_capacity / 4));
    if (last_delay_revision_us_ == 0) input_delay_ = want;  // the first estimate, before frame 0
    else if (want > input_delay_) ++input_delay_;
    else if (want < input_delay_) --input_delay_;
    last_delay_revision_us_ = now_us;
}

// ---- ticking ----

void RelaySessionImpl::add_own_input(std::span<const std::uint8_t> input) {
    if (config_.role == RelayRole::Spectator) return;
    const std::uint32_t target = std::max(frame() + static_cast<std::uint32_t>(input_delay_), handoff_);
    std::uint32_t next = own_.confirmed_count();
    if (target < next) {
        ++stats_.dropped_local_inputs;  // the delay shrank: sent inputs never change
        return;
    }
    scratch_.assign(local_input_size(), 0);
    if (const auto last = own_.last_confirmed(); !last.empty()) scratch_.assign(last.begin(), last.end());
    for (; next < target; ++next)
        if (own_.add_confirmed(next, scratch_) != InputQueue::Add::Stored) return;
    own_.add_confirmed(target, input);
}

void RelaySessionImpl::confirm_frames() {
    while (!sync_->rollback_pending() && sync_->confirmed_frame() < sync_->confirmable_frame()) {
        const FrameConfirmed fc = sync_->confirm_next();
        if (observer_) observer_->on_frame_confirmed(fc);
        confirmed_checksums_[fc.frame % kConfirmedKept] = fc.checksum;
        confirmed_frames_[fc.frame % kConfirmedKept] = fc.frame;
        if (checksum_interval_ && fc.frame % checksum_interval_ == 0 && config_.role != RelayRole::Spectator) {
            if (reports_.size() >= kMaxReports) reports_.pop_front();
            reports_.push_back({fc.frame, fc.checksum, kChecksumRepeats});
        }
    }
    // Own inputs the server holds and this client has seen confirmed are never read again.
    if (config_.role != RelayRole::Spectator) {
        std::uint32_t seen = server_ack_;
        for (PlayerId p : local_slots_) seen = std::min(seen, sync_->queue(p).confirmed_count());
        own_.discard_before(seen);
    }
}

AdvanceResult RelaySessionImpl::advance_impl(std::span<const std::uint8_t> local_input, std::uint64_t now_us) {
    if (!incarnation_) incarnation_ = config_.incarnation ? config_.incarnation : now_us | 1;
    AdvanceResult r;
    ++stats_.ticks;
    if (phase_ != SessionPhase::Running) {
        r.frame = frame();
        return r;
    }
    // A caller's bug, handled as the P2P session does (session.h): counted, and the tick does
    // nothing; it used to fail the session here.
    if (local_input.size() != local_input_size()) {
        ++stats_.bad_local_inputs;
        r.frame = frame();
        return r;
    }
    const std::uint64_t t0 = config_.cpu_clock();
    r.rollback_depth = sync_->rollback_if_needed();
    if (r.rollback_depth) r.resim_ns = config_.cpu_clock() - t0;
    confirm_frames();
    revise_input_delay(now_us);
    const bool held = frame() >= last_frame_;  // set_last_frame(): rollbacks and confirmations go on
    if (!held) add_own_input(local_input);
    if (held) {
    } else if (sync_->must_wait(0)) {
        stall_.stalled(now_us, stats_);
        r.blocking_player = sync_->blocking_player();
    } else {
        stall_.stepped(now_us, stats_);
        const std::uint64_t t1 = config_.cpu_clock();
        sync_->step_forward();
        r.forward_ns = config_.cpu_clock() - t1;
        r.advanced = true;
        confirm_frames();
    }
    r.frame = frame();
    // Pacing: ahead of the target lead, lengthen ticks in proportion (at most kMaxTickStretchPpm,
    // as the P2P session: a client clock 8 % fast outran a 5 % cap into its window).
    if (const auto clock = room_clock(now_us)) {
        const std::int64_t lead = static_cast<std::int64_t>(frame()) * kFrac - *clock;
        relay_stats_.lead_x100 = lead * 100 / kFrac;
        relay_stats_.target_lead = target_lead();
        const std::int64_t excess = lead - target_lead() * kFrac;
        if (excess > kFrac / 2)
            r.tick_stretch_ppm = static_cast<int>(
                std::min<std::int64_t>(kMaxTickStretchPpm, excess * 1000000 / (kFrac * config_.tick_rate)));
    }
    return r;
}

int RelaySessionImpl::catch_up_impl(std::uint64_t now_us, int max_frames) {
    int stepped = 0;
    const int want = std::min(max_frames, static_cast<int>(behind(now_us)));
    while (stepped < want && phase_ == SessionPhase::Running) {
        if (sync_->rollback_pending()) sync_->rollback_if_needed();
        if (sync_->must_wait(0) || frame() >= last_frame_) break;
        if (config_.role != RelayRole::Spectator) {
            // The skipped tick's input repeats the last one.
            scratch_.assign(local_input_size(), 0);
            if (const auto last = own_.last_confirmed(); !last.empty()) scratch_.assign(last.begin(), last.end());
            const std::vector<std::uint8_t> input = scratch_;
            add_own_input(input);
        }
        sync_->step_forward();
        confirm_frames();
        ++stepped;
    }
    return stepped;
}

void RelaySessionImpl::poll_impl(std::uint64_t now_us, std::vector<Datagram>& out) {
    if (!incarnation_) incarnation_ = config_.incarnation ? config_.incarnation : now_us | 1;
    if (phase_ == SessionPhase::Failed) {
        pending_out_.clear();
        return;
    }
    // A started room sends every tick; before the start it sends nothing, so only then.
    const bool in_room = phase_ == SessionPhase::Running || phase_ == SessionPhase::Transferring;
    if (in_room && config_.server_timeout_us && last_server_us_ && now_us > last_server_us_ + config_.server_timeout_us) {
        const std::string why = "the relay server is silent for " + std::to_string((now_us - last_server_us_) / 1000) + " ms";
        emit(SessionEvent::Kind::ServerLost, SessionEvent::Reason::ServerSilent, kRelayServerPeer, frame(), now_us, why);
        server_lost_ = true;
        pending_out_.clear();
        return fail(SessionEvent::Reason::ServerSilent, why, now_us);
    }
    if (!welcomed_ && (!hello_sent_ || now_us - last_hello_us_ >= config_.hello_resend_us)) {
        RelayHello h;
        h.room_id = config_.room_id;
        h.scene_checksum = config_.scene_checksum;
        h.players = static_cast<std::uint8_t>(config_.players);
        h.input_size = static_cast<std::uint8_t>(config_.input_size);
        h.tick_rate = static_cast<std::uint16_t>(config_.tick_rate);
        h.role = config_.role;
        h.slot = static_cast<std::uint8_t>(config_.role == RelayRole::Spectator ? 0 : config_.local_slot);
        h.also_slots = config_.role == RelayRole::Spectator ? 0 : config_.also_slots;
        h.absent_slots = config_.absent_slots;
        h.incarnation = incarnation_;
        h.stamp_us = now_us;
        h.token = config_.connect_token;
        Datagram d{kRelayServerPeer, {}, true};
        encode(h, d.bytes);
        pending_out_.push_back(std::move(d));
        hello_sent_ = true;
        last_hello_us_ = now_us;
    }
    if (transfer_from_ && config_.transfer_timeout_us && now_us > transfer_progress_us_ + config_.transfer_timeout_us)
        return fail(SessionEvent::Reason::TransferStalled,
                    "snapshot from id " + std::to_string(*transfer_from_) + ": no progress for " +
                        std::to_string((now_us - transfer_progress_us_) / 1000) + " ms",
                    now_us);
    if (transfer_from_) {
        const std::uint8_t from = *transfer_from_;
        if (!incoming_) {
            if (!last_offer_request_us_ || now_us - last_offer_request_us_ >= config_.transfer_resend_us) {
                SnapshotRequestMessage q;
                q.reason = transfer_reason_;
                scratch_.clear();
                encode(q, scratch_);
                send_forward(from, scratch_);
                last_offer_request_us_ = now_us;
            }
        } else {
            std::vector<std::uint32_t> due;
            incoming_->due_requests(now_us, config_.transfer_resend_us, config_.transfer_window, due);
            for (std::uint32_t c : due) {
                SnapshotRequestMessage q;
                q.reason = transfer_reason_;
                q.transfer_id = incoming_->offer().transfer_id;
                q.chunk = c;
                scratch_.clear();
                encode(q, scratch_);
                send_forward(from, scratch_);
            }
        }
    }
    if (welcomed_) {
        // One input message per tick: own inputs the server lacks, acks, stamps, checksums. It is
        // also the keepalive before the room starts and while a snapshot loads.
        RelayInput m;
        m.confirmed_ack = phase_ == SessionPhase::Running ? sync_->inputs_complete() : kRelayNoFrames;
        if (config_.role != RelayRole::Spectator && phase_ == SessionPhase::Running) {
            // Own inputs the server lacks.
            const auto run = own_.copy_confirmed(server_ack_, relay_max_inputs(local_input_size()), m.inputs);
            m.first_frame = run.first;
            m.frame_count = static_cast<std::uint8_t>(run.count);
            m.slots = run.count > 0 ? relay_local_slots(config_) : 0;
        }
        const PeerLink::Stamps st = link_.outgoing_stamps(now_us);
        m.stamp = st.stamp;
        m.echo = st.echo;
        m.hold = st.hold;
        for (auto& rep : reports_) {
            if (m.checksum_count >= kRelayMaxChecksums) break;
            m.checksum_frames[m.checksum_count] = rep.frame;
            m.checksums[m.checksum_count] = rep.checksum;
            ++m.checksum_count;
            --rep.sends;
        }
        std::erase_if(reports_, [](const Report& r) { return r.sends <= 0; });
        Datagram d{kRelayServerPeer, {}, false};
        encode(m, config_.input_size, d.bytes);
        pending_out_.push_back(std::move(d));
    }
    for (auto& d : pending_out_) {
        ++stats_.packets_sent;
        stats_.bytes_sent += d.bytes.size();
        out.push_back(std::move(d));
    }
    pending_out_.clear();
}

// ---- the per-tick calls: SessionCore::guarded turns anything thrown into a failed session ----

void RelaySessionImpl::receive(std::span<const std::uint8_t> d, std::uint64_t now_us) noexcept {
    guarded("receive", now_us, [&] { receive_impl(d, now_us); });
}

AdvanceResult RelaySessionImpl::advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept {
    return guarded("advance", now_us, [&] { return advance_impl(local_input, now_us); }, [&] { return idle_result(); });
}

void RelaySessionImpl::poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept {
    guarded("poll", now_us, [&] { poll_impl(now_us, out); });
}

int RelaySessionImpl::catch_up(std::uint64_t now_us, int max_frames) noexcept {
    return guarded("catch_up", now_us, [&] { return catch_up_impl(now_us, max_frames); }, [] { return 0; });
}

}  // namespace lockroll::rollback
