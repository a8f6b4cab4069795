#include "rollback/session_impl.h"

#include "rollback/confirm_floors.h"
#include "rollback/input_authority.h"
#include "rollback/frame_pacing.h"
#include "rollback/handshake.h"
#include "rollback/input_delay.h"
#include "rollback/join_handoff.h"
#include "rollback/recovery_source.h"
#include "rollback/rejoin.h"
#include "rollback/session_admission.h"
#include "rollback/session_effects.h"

#include <algorithm>
#include <array>
#include <functional>
#include <limits>
#include <stdexcept>

namespace lockroll::rollback {

namespace {
std::uint32_t next_pow2(std::uint64_t v) {
    std::uint32_t p = 1;
    while (p < v) p <<= 1;
    return p;
}

std::int8_t clamp_i8(std::int64_t v) { return static_cast<std::int8_t>(std::clamp<std::int64_t>(v, -127, 127)); }
}  // namespace

// Forwards every callback to the owner's observer, and lets the session react to desyncs.
class SessionImpl::Tap final : public SessionObserver {
public:
    Tap(SessionImpl& s, SessionObserver* next) : s_(s), next_(next) {}
    void on_frame_simulated(const FrameSimulated& f) override {
        if (next_) next_->on_frame_simulated(f);
    }
    void on_rollback_begin(const RollbackInfo& r) override {
        if (next_) next_->on_rollback_begin(r);
    }
    void on_rollback_end(const RollbackInfo& r) override {
        if (next_) next_->on_rollback_end(r);
    }
    void on_frame_confirmed(const FrameConfirmed& f) override {
        if (next_) next_->on_frame_confirmed(f);
    }
    void on_desync(const DesyncEvent& e) override {
        s_.emit(SessionEvent::Kind::DesyncDetected, SessionEvent::Reason::ChecksumMismatch, e.peer, e.frame, s_.last_now_us_,
                "confirmed checksums differ");
        if (!s_.mismatch_frame_ || e.frame < *s_.mismatch_frame_) s_.mismatch_frame_ = e.frame;
        s_.mismatch_since_us_ = s_.last_now_us_;
        if (next_) next_->on_desync(e);
    }
    void on_desync_report(const DesyncReport& r) override {
        if (next_) next_->on_desync_report(r);
    }
    void on_peer_error(PlayerId p, const std::string& e) override {
        if (next_) next_->on_peer_error(p, e);
    }

private:
    SessionImpl& s_;
    SessionObserver* next_;
};

// A game that saved more than it declared: its states cannot be kept, so the session stops.
static std::string oversized_message(const Simulation& sim) {
    return "the simulation saved " + std::to_string(sim.saved_size()) + " bytes, more than its state_size() of " +
           std::to_string(sim.state_size());
}

SessionImpl::SessionImpl(const SessionConfig& config, Simulation& simulation, SessionObserver* observer,
                 Predictor* predictor)
    : SessionCore(SessionPhase::Running, config.local_player, config.input_delay, observer),
      config_(config),
      sim_(simulation),
      membership_(0, 0, config.two_player_rule),
      effects_(std::make_unique<Effects>(*this)),
      changes_(config_, membership_, slots_, links_, stats_, *effects_),
      authored_(config_, membership_, slots_, links_, *effects_),
      fetch_(config_, simulation.state_size()),
      pacing_(config_),
      handshake_(config_, membership_) {
    validate(config_);
    membership_ = Membership(config_.players, config_.local_player, config_.two_player_rule, config_.slot_hosts);
    default_to_zero(config_.cpu_clock);
    if (config_.relay_lag == 0) config_.relay_lag = config_.prediction_window + config_.input_delay + 8;
    tap_ = std::make_unique<Tap>(*this, observer_);
    const auto peers = static_cast<std::size_t>(peers_total());
    stats_.peers.resize(peers);
    // A spectator has no slot of its own; its Sync is built as slot 0's, which it never feeds.
    SyncConfig sc = sync_config(config_.players, config_.role == Role::Spectator ? 0 : config_.local_player, config_.input_size,
                                config_.prediction_window, config_.evidence_frames, config_.input_capacity);
    // A quarter of the ring stays behind confirmation: a peer reloading a snapshot of a slightly
    // older frame (a desync recovery) still finds its own and everyone's inputs since then.
    sc.retain_frames = config_.input_capacity / 4;
    sync_ = std::make_unique<Sync>(sc, sim_, predictor_or_default(predictor), tap_.get(), stats_, config_.cpu_clock);
    DesyncConfig dc;
    dc.history = next_pow2(std::max<std::uint64_t>(
        1024, 2 * static_cast<std::uint64_t>(config_.checksum_interval) +
                  static_cast<std::uint64_t>(config_.evidence_frames + config_.prediction_window)));
    dc.max_pinned_frames = std::clamp(2 * config_.checksum_interval + 8, 10, 64);
    dc.resend_us = config_.query_resend_us;
    detector_ = std::make_unique<DesyncDetector>(dc, peers_total(), config_.local_player, sim_, sync_->ring(),
                                                 tap_.get(), stats_);
    authority_ = std::make_unique<InputAuthority>(config_.players, peers_total());
    if (stats_.oversized_states > 0) throw std::invalid_argument(oversized_message(sim_));
    detector_->add_local(0, sync_->initial_checksum());
    scene_checksum_ = config_.scene_checksum != 0 ? config_.scene_checksum : sync_->initial_checksum();
    links_.reserve(peers);
    for (std::size_t p = 0; p < peers; ++p) {
        links_.emplace_back(config_.max_bad_packets, config_.time_sync_window);
        links_.back().reset_lifecycle(static_cast<std::size_t>(config_.players));
    }
    local_advantage_.assign(peers, 0);
    replies_this_poll_.assign(peers, 0);
    slots_.assign(static_cast<std::size_t>(config_.players), SlotView{});
    if (config_.role != Role::Spectator)
        for (int s = 0; s < config_.players; ++s)
            if (static_cast<PlayerId>(s) == config_.local_player || my_guest(static_cast<PlayerId>(s)))
                local_slots_.push_back(static_cast<PlayerId>(s));
    for (int s = 0; s < config_.players; ++s)
        if (config_.absent_slots >> s & 1) membership_.set(static_cast<PlayerId>(s), SlotState::Absent, 0);
    if (config_.role != Role::Player) {
        // Everything but what the snapshot will tell: the newcomer knows nothing yet.
        phase_ = SessionPhase::Synchronizing;
    } else if (config_.handshake) {
        phase_ = SessionPhase::Synchronizing;
    } else {
        for (std::size_t p = 0; p < static_cast<std::size_t>(config_.players); ++p) links_[p].welcomed = true;
    }
    // The starting view is every peer's (the same config): it is no change to anyone.
    const StreamRelay relay(stream_view());
    for (std::size_t p = 0; p < peers; ++p) {
        relay.table_entries_for(static_cast<PlayerId>(p), table_entries_);
        links_[p].table_assumed(table_entries_, 0);
    }
    refresh_resend_floor();
}

SessionImpl::~SessionImpl() = default;

// The per-tick calls: SessionCore::guarded turns anything thrown into a failed session.
void SessionImpl::receive(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us) noexcept {
    guarded("receive", now_us, [&] { receive_impl(from, datagram, now_us); });
}

AdvanceResult SessionImpl::advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept {
    return guarded("advance", now_us, [&] { return advance_impl(local_input, now_us); }, [&] { return idle_result(); });
}

int SessionImpl::catch_up(std::uint64_t now_us, int max_frames) noexcept {
    return guarded("catch_up", now_us, [&] { return catch_up_impl(now_us, max_frames); }, [] { return 0; });
}

void SessionImpl::poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept {
    guarded("poll", now_us, [&] { poll_impl(now_us, out); });
}

void SessionImpl::send_control(PlayerId to, std::vector<std::uint8_t> bytes) {
    // Hellos and welcomes go unreliable: a hello is said again every hello_resend_us until
    // answered and every one is answered, and they carry the round trip's stamp. On a reliable
    // channel (ENet's: retransmission backing off, in order) a lost one would hold back those
    // behind it, turning 30 % loss into round trips of seconds and into retransmissions that
    // make ENet close the connection. The rest (snapshot transfer) is reliable where possible.
    const auto kind = peek_kind(bytes);
    const bool reliable = kind != MessageKind::Hello && kind != MessageKind::Welcome;
    Datagram d{to, std::move(bytes), reliable};
    pending_out_.push_back(std::move(d));
}

bool SessionImpl::live_peer(PlayerId p) const {
    if (p == config_.local_player || p >= links_.size() || is_guest(p)) return false;
    const PeerLink& l = links_[p];
    if (!l.welcomed || l.error()) return false;
    if (is_slot(p)) return slot_running(p);
    return l.role == Role::Spectator;
}

void SessionImpl::malformed(PlayerId from, const char* why) {
    ++stats_.malformed_packets;
    ++stats_.peers[from].malformed_packets;
    if (links_[from].note_malformed(why)) {
        stats_.peers[from].error = true;
        detector_->peer_failed(from);
        refresh_resend_floor();
        if (observer_) observer_->on_peer_error(from, why);
    }
}

void SessionImpl::receive_impl(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us) {
    last_now_us_ = std::max(last_now_us_, now_us);
    ++stats_.packets_received;
    stats_.bytes_received += datagram.size();
    if (from >= static_cast<PlayerId>(peers_total()) || from == config_.local_player) {
        ++stats_.unknown_peer_packets;
        return;
    }
    PeerStats& ps = stats_.peers[from];
    ++ps.packets_received;
    ps.bytes_received += datagram.size();
    if (phase_ == SessionPhase::Failed) {
        ++ps.ignored_packets;
        return;
    }
    // A joiner not yet loaded (or a player before frame 0, should it turn out to be a restarted
    // process): whatever a slot's process says, it is reached.
    if (config_.role != Role::Spectator && phase_ != SessionPhase::Running && is_slot(from)) reach_.heard(from, now_us);
    const auto kind = peek_kind(datagram);
    // A hello is always heard (a rejoining process replaces a failed one); the rest only from a
    // peer that is listened to.
    if (kind == MessageKind::Hello) {
        if (const char* e = decode(datagram, hello_msg_)) return malformed(from, e);
        return handle_hello(from, hello_msg_, now_us);
    }
    if (links_[from].error()) {
        ++ps.ignored_packets;
        return;
    }
    if (!kind) return malformed(from, "unknown message kind");
    PeerLink& link = links_[from];
    // Any message from a welcomed peer proves it alive (a joiner pulling chunks sends no inputs).
    if (link.welcomed && (!is_slot(from) || slot_running(from))) {
        if (link.hear(now_us)) emit(SessionEvent::Kind::Resumed, SessionEvent::Reason::Heard, from, frame(), now_us);
        // Heard again: our vote that it is gone is withdrawn (a partition healed). A kick stays, and
        // so does a lapsed handoff's vote until the joiner's stream starts (check_handoff).
        if (is_slot(from) && !slots_[from].kick_vote && !slots_[from].lapse_vote) membership_.vote_local(from, false);
    }
    switch (*kind) {
        case MessageKind::Hello: return;
        case MessageKind::Welcome:
            if (const char* e = decode(datagram, welcome_msg_)) return malformed(from, e);
            return handle_welcome(from, welcome_msg_, now_us);
        case MessageKind::SnapshotRequest:
            if (const char* e = decode(datagram, snap_req_msg_)) return malformed(from, e);
            if (!link.welcomed) return void(++ps.ignored_packets);
            return handle_snapshot_request(from, snap_req_msg_, now_us);
        case MessageKind::SnapshotOffer:
            if (const char* e = decode(datagram, snap_offer_msg_)) return malformed(from, e);
            if (!link.welcomed) return void(++ps.ignored_packets);
            return handle_snapshot_offer(from, snap_offer_msg_, now_us);
        case MessageKind::SnapshotChunk:
            if (const char* e = decode(datagram, snap_chunk_msg_)) return malformed(from, e);
            if (!link.welcomed) return void(++ps.ignored_packets);
            return handle_snapshot_chunk(from, snap_chunk_msg_, now_us);
        default: break;
    }
    // A newcomer vetting its snapshot: the peers' confirmed checksums of its frame.
    if (*kind == MessageKind::Reply && fetch_.vetting()) {
        if (const char* e = decode(datagram, reply_msg_)) return malformed(from, e);
        return fetch_.take_reply(from, reply_msg_);
    }
    // Input, query, reply: game traffic. A newcomer has no frame to relate it to until its
    // snapshot is loaded; a player still synchronizing already does (frame 0).
    if (phase_ != SessionPhase::Running && config_.role != Role::Player) return void(++ps.ignored_packets);
    // A welcomed joiner's query (its snapshot's vetting) is answered before its slot runs.
    if (!link.welcomed || (is_slot(from) && !slot_running(from) && *kind != MessageKind::Query)) {
        ++ps.ignored_packets;
        // A dropped slot's process still talking, or a spectator we stopped serving (it timed
        // out: cut off from us past disconnect_us): tell it, now and then. The spectator then
        // starts again, by a fresh snapshot (rollback/rejoin.h).
        const bool dropped = is_slot(from) ? slot_state(from) == SlotState::Disconnected : link.role == Role::Spectator;
        if (dropped && link.refusal_quiet_for(now_us, 500000)) {
            WelcomeMessage w;
            w.refusal = Refusal::Disconnected;
            w.match_id = config_.match_id;
            w.scene_checksum = scene_checksum_;
            w.slot_epoch = is_slot(from) ? membership_.epoch(from) : 0;  // a spectator has no slot epoch
            std::vector<std::uint8_t> b;
            encode(w, b);
            send_control(from, std::move(b));
            link.mark_refusal(now_us);
        }
        return;
    }
    switch (*kind) {
        case MessageKind::Input:
            if (const char* e = decode(datagram, config_.input_size, in_msg_)) return malformed(from, e);
            if (phase_ == SessionPhase::Synchronizing && is_slot(from)) {
                handshake_.peer_started();  // it plays already: follow it
                maybe_start(now_us);
            }
            // What the message changes is InputIntake's; what the session does about it --
            // membership actions, a malformed message, events -- is Effects' forwards
            // (rollback/session_effects.h).
            return InputIntake(intake_state(), *effects_).apply(from, in_msg_, now_us);
        case MessageKind::Query: {
            if (const char* e = decode(datagram, query_msg_)) return malformed(from, e);
            if (replies_this_poll_[from] >= config_.max_replies_per_poll) {
                ++ps.ignored_packets;
                return;
            }
            ++replies_this_poll_[from];
            Datagram d{from, {}, false};
            encode(detector_->answer(query_msg_), d.bytes);
            pending_out_.push_back(std::move(d));
            return;
        }
        case MessageKind::Reply:
            if (const char* e = decode(datagram, reply_msg_)) return malformed(from, e);
            detector_->on_reply(from, reply_msg_);
            return;
        default: return;
    }
}

// What a hello or welcome means is the Handshake's (rollback/handshake.h) and admit_hello's
// (rollback/session_admission.h); the session does it.
void SessionImpl::handle_hello(PlayerId from, const HelloMessage& m, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    const bool running = phase_ == SessionPhase::Running;
    HelloContext c =
        handshake_.hello_context(from, link, running, scene_checksum_, is_slot(from) && slots_[from].handed_off_by_me);
    c.silent_us = now_us > link.last_heard_us ? now_us - link.last_heard_us : 0;
    c.interrupt_us = config_.interrupt_us;
    const HelloAdmission a = admit_hello(m, c);
    // Another process claims the slot restarted. Once the claim has stood, the old process
    // unheard, for restart_confirm_us (rollback/restart_claim.h), and that process is quiet, it
    // is our vote that the old one is gone; welcome a joiner once a majority dropped it. A
    // player is refused as dropped in the drop's epoch (newer than its view's, so its vote counts
    // there and it rejoins), and asked to retry until then. A doubted claim (the old process
    // was heard lately) is noted too: the window runs from the claim's first hello.
    Refusal refusal = a.refusal;
    if ((a.restarted || a.doubted) && !changes_.claim_restart(from, m.role == Role::Player, a.restarted, now_us))
        refusal = Refusal::Retry;
    const WelcomeMessage w = handshake_.answer(from, m, running, scene_checksum_, refusal);
    if ((w.refusal != Refusal::None && w.refusal != Refusal::Retry) || a.doubted) {
        ++foreign_packets_;
        if (Handshake::refusal_reported(link, now_us))
            emit(SessionEvent::Kind::Refused,
                 a.doubted ? SessionEvent::Reason::RestartDoubted : Handshake::refusal_reason(w.refusal), from, frame(),
                 now_us, "refused hello: " + a.why);
    }
    if (w.refusal == Refusal::None) {
        if (handshake_.new_process(from, link, m.role)) {
            link.reset_lifecycle(static_cast<std::size_t>(config_.players));
            link.clear_error();
            detector_->reset_peer(from);
        }
        link.accept_hello(m.role, m.incarnation, is_slot(from) ? std::optional(membership_.epoch(from)) : std::nullopt, now_us);
    }
    if (w.refusal != Refusal::None) {
        if (!Handshake::refusal_answered(w.refusal, link, now_us)) return;
        link.mark_refusal(now_us);
    }
    std::vector<std::uint8_t> b;
    encode(w, b);
    send_control(from, std::move(b));
}

void SessionImpl::handle_welcome(PlayerId from, const WelcomeMessage& m, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    using Act = Handshake::WelcomeVerdict::Act;
    const Handshake::WelcomeVerdict v = handshake_.judge_welcome(from, m, phase_, link, scene_checksum_);
    if (v.restarted) reach_.told_restarted();  // judged as a joiner from the next poll on
    switch (v.act) {
        case Act::Ignore: return;
        case Act::SpectatorDropped:
            emit(SessionEvent::Kind::Kicked, SessionEvent::Reason::SpectatorDropped, config_.local_player, frame(), now_us,
                 "peer " + std::to_string(from) + " says this spectator was dropped");
            return fail(SessionEvent::Reason::Dropped, drop_failure(config_), now_us);
        case Act::VoteGone:  // in the epoch the sender dropped our slot into
            return changes_.refused_as_dropped(from, m.slot_epoch, now_us);
        case Act::Refused:
            emit(SessionEvent::Kind::Refused, v.reason, from, frame(), now_us, v.why);
            if (phase_ != SessionPhase::Running) fail(v.reason, v.why, now_us);
            return;
        case Act::LateWelcome:
            link.late_welcome(membership_.epoch(from), m.echo_us, now_us);
            if (m.echo_us <= now_us) stats_.peers[from].rtt_us = link.rtt_us();
            emit(SessionEvent::Kind::Synchronizing, SessionEvent::Reason::LateWelcome, from, 1, now_us);
            return refresh_resend_floor();
        case Act::SyncRoundTrip:
            handshake_.sync_welcome(link, is_slot(from), m, now_us);
            if (m.echo_us <= now_us) stats_.peers[from].rtt_us = link.rtt_us();
            if (m.running) link.role = is_slot(from) ? Role::Player : Role::Spectator;
            emit(SessionEvent::Kind::Synchronizing, SessionEvent::Reason::RoundTrip, from, static_cast<std::uint32_t>(link.roundtrips),
                 now_us);
            return maybe_start(now_us);
    }
}

// The start rule is the Handshake's (rollback/handshake.h).
void SessionImpl::maybe_start(std::uint64_t now_us) {
    if (handshake_.ready_to_start(links_, phase_)) start_running(now_us);
}

void SessionImpl::start_running(std::uint64_t now_us) {
    phase_ = SessionPhase::Running;
    started_us_ = now_us;
    const std::uint64_t worst = handshake_.start(links_, now_us);
    if (config_.auto_input_delay && config_.role == Role::Player) {
        // The one policy (rollback/input_delay.h); a P2P input reaches its peers in half the worst round trip.
        const int d = auto_input_delay(config_.prediction_window, worst / 2, config_.tick_rate);
        input_delay_ = std::clamp(d, 0, static_cast<int>(config_.input_capacity / 4));
    }
    emit(SessionEvent::Kind::Synchronized, SessionEvent::Reason::Handshake, config_.local_player, frame(), now_us,
         "input delay " + std::to_string(input_delay_) + ", worst sync rtt " + std::to_string(worst / 1000) + " ms");
}

IntakeState SessionImpl::intake_state() {
    return {config_, membership_, *sync_, *authority_, links_, slots_, stats_.peers, detector_->newest_local(),
            pacing_.advantage_bound(input_delay_)};
}

// The floors' rules are rollback/confirm_floors.h's; the session applies them to Sync.
void SessionImpl::refresh_resend_floor() {
    if (config_.role == Role::Spectator) return;
    sync_->set_keep_from(config_.local_player,
                         resend_floor(links_, live(), count_of(config_.local_player), config_.input_capacity));
}

// A spectator too far behind (rollback/confirm_floors.h, spectator_lags) is cut loose as if it
// had timed out: its next message is answered "dropped", and it starts again by a snapshot.
void SessionImpl::cut_loose_lagging_spectators(std::uint64_t now_us) {
    if (config_.role == Role::Spectator) return;
    for (std::size_t p = static_cast<std::size_t>(config_.players); p < links_.size(); ++p) {
        PeerLink& l = links_[p];
        if (!live_peer(static_cast<PlayerId>(p)) ||
            !spectator_lags(l, config_.local_player, count_of(config_.local_player), config_.input_capacity))
            continue;
        l.welcomed = false;
        emit(SessionEvent::Kind::Disconnected, SessionEvent::Reason::SpectatorLagged, static_cast<PlayerId>(p), frame(), now_us,
             "spectator fell " + std::to_string(count_of(config_.local_player) - l.remote_ack) + " inputs behind");
    }
}

void SessionImpl::refresh_keep_floors(std::uint64_t now_us) {
    for (int s = 0; s < config_.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (config_.role != Role::Spectator && slot == config_.local_player) continue;
        sync_->set_keep_from(slot, keep_floor(slot, links_, live(), now_us, sync_->confirmed_frame(), config_.input_capacity));
    }
}

std::uint32_t SessionImpl::confirm_limit() const {
    ConfirmBounds b;
    b.confirmable = sync_->confirmable_frame();
    b.others = config_.role == Role::Spectator ? 0 : membership_.majority_size() - 1;
    if (b.others <= 0) return b.confirmable;
    std::array<std::uint32_t, kMaxPlayers> held{};
    std::size_t n = 0;
    const auto guests = std::span<const PlayerId>(local_slots_).subspan(std::min<std::size_t>(1, local_slots_.size()));
    for (int p = 0; p < config_.players; ++p)
        if (live_peer(static_cast<PlayerId>(p))) held[n++] = held_of_ours(links_[static_cast<std::size_t>(p)], guests);
    b.frame = sync_->frame();
    b.saved_span = static_cast<std::uint32_t>(config_.prediction_window + config_.evidence_frames / 2);
    b.unverified = authority_->first_unverified(sync_->confirmed_frame()).value_or(b.confirmable);
    return rollback::confirm_limit(b, std::span<const std::uint32_t>(held.data(), n));
}

void SessionImpl::confirm_frames() {
    const std::uint32_t limit = confirm_limit();
    while (sync_->confirmed_frame() < limit) {
        const FrameConfirmed fc = sync_->confirm_next();
        detector_->add_local(fc.frame, fc.checksum);
        if (observer_) observer_->on_frame_confirmed(fc);
    }
    for (int s = 0; s < config_.players; ++s)
        authority_->forget_before(static_cast<PlayerId>(s), sync_->queue(static_cast<PlayerId>(s)).floor());
}

// Time sync against the live player peers (rollback/frame_pacing.h).
bool SessionImpl::paces(PlayerId p) const { return live_peer(p) && is_slot(p); }

void SessionImpl::sample_time_sync(std::uint64_t now_us) {
    pacing_.sample(links_, pacer(), sync_->frame(), input_delay_, now_us, local_advantage_, stats_.peers);
}

std::int32_t SessionImpl::frames_ahead_x100() const { return pacing_.frames_ahead_x100(links_, pacer()); }

std::int32_t SessionImpl::behind(std::uint64_t now_us) const {
    return pacing_.behind(links_, pacer(), sync_->frame(), now_us);
}

NetworkStats SessionImpl::network_stats(PlayerId p, std::uint64_t now_us) const {
    if (p >= links_.size() || p == config_.local_player) return {};
    const double seconds = now_us > started_us_ ? static_cast<double>(now_us - started_us_) / 1e6 : 0;
    const OverlayClock at{sync_->frame(), seconds, now_us, config_.interrupt_us, config_.tick_rate};
    const auto sent = config_.role != Role::Spectator ? std::optional(count_of(config_.local_player)) : std::nullopt;
    return rollback::network_stats(links_[p], stats_.peers[p], at, sent);
}

// How far ahead of local_target() an input must go to reach everyone before they need it: the
// worst round trip (the given one, and every live peer's; 100 ms unmeasured) in frames, + 2. The
// owner's handoff frame and a joiner's lead over its own frame (joiner_input) are this far ahead.
std::uint32_t SessionImpl::lead_frames(std::uint64_t rtt) const {
    const std::uint64_t tick_us = 1000000 / static_cast<std::uint64_t>(config_.tick_rate);
    for (std::size_t p = 0; p < links_.size(); ++p)
        if (live_peer(static_cast<PlayerId>(p))) rtt = std::max(rtt, links_[p].rtt_us());
    if (rtt == 0) rtt = 100000;
    return static_cast<std::uint32_t>(rtt / tick_us) + 2;
}

std::uint32_t SessionImpl::local_target() const { return sync_->frame() + static_cast<std::uint32_t>(input_delay_); }

AdvanceResult SessionImpl::advance_impl(std::span<const std::uint8_t> local_input, std::uint64_t now_us) {
    AdvanceResult result;
    result.frame = sync_->frame();
    const std::size_t expected = std::max<std::size_t>(local_slots_.size(), 1) * config_.input_size;
    if (local_input.size() != expected) {
        ++stats_.bad_local_inputs;
        return result;
    }
    last_now_us_ = std::max(last_now_us_, now_us);
    if (phase_ != SessionPhase::Running) return result;
    ++stats_.ticks;
    changes_.check_silence(now_us);
    if (phase_ != SessionPhase::Running) return result;
    consider_recovery(now_us);
    authored_.author_absent_streams(local_target(), now_us);
    const std::uint64_t resim_before = stats_.resim_ns;
    result.rollback_depth = sync_->rollback_if_needed();
    result.resim_ns = stats_.resim_ns - resim_before;
    confirm_frames();
    sample_time_sync(now_us);
    cut_loose_lagging_spectators(now_us);
    refresh_keep_floors(now_us);
    // Every tick, not only on the acks and lifecycle changes that call it: the set of live peers
    // also changes where no call was made (a spectator timing out), and a floor left on a peer
    // that is gone would hold our stream until the queue is full -- a stall that never ends.
    refresh_resend_floor();
    const bool spectator = config_.role == Role::Spectator;
    // The local input goes to frame() + delay whether or not this tick can step: in lockstep
    // both sides wait for each other's input of the same frame, so it must be sent while
    // waiting. While stalled that frame already has its input and later ones are not used. A
    // joiner still catching up sends one input per tick for the frames the match is at.
    bool input_taken = false;
    if (!spectator) {
        const std::uint32_t count = count_of(config_.local_player);
        // One rule (rollback/rejoin.h, joiner_input): one input per tick, within a round trip's
        // lead of our frame (the lead the owner gave the handoff frame).
        const JoinerInput pace = joiner_input(joining_, count, local_target(), lead_frames(0));
        joining_ = pace.joining;
        const std::uint32_t min_frame = pace.min_frame;
        const std::uint32_t target = std::max(local_target(), min_frame);
        const InputQueue& local = sync_->queue(config_.local_player);
        const std::size_t n = config_.input_size;
        if (std::uint64_t{target} < std::uint64_t{local.floor()} + local.capacity())
            input_taken = sync_->add_local_input(local_input.first(n), input_delay_, min_frame);
        authored_.author_guest_streams(local_slots_, local_input.subspan(n));
    }
    const bool wait = spectator ? sync_->frame() >= sync_->inputs_complete()
                                : sync_->must_wait(input_delay_);
    if (sync_->frame() >= last_frame_) {
        // Held at the last frame (set_last_frame): inputs, rollbacks and confirmations go on.
    } else if (wait) {
        stall_.stalled(now_us, stats_);
        result.blocking_player = sync_->blocking_player();
    } else {
        const bool ended_stall = stall_.stepped(now_us, stats_);
        if (!ended_stall && !input_taken && !spectator && !joining_) ++stats_.dropped_local_inputs;  // the delay just shrank
        const std::uint64_t forward_before = stats_.forward_ns;
        sync_->step_forward();
        result.forward_ns = stats_.forward_ns - forward_before;
        result.advanced = true;
        confirm_frames();
    }
    if (stats_.oversized_states > 0) fail(SessionEvent::Reason::StateTooLarge, oversized_message(sim_), now_us);
    result.frame = sync_->frame();
    // Time sync: at most one recommendation per window, and the same advice as a gentle slowdown.
    result.wait_frames = pacing_.recommend_wait(links_, pacer(), result.frame, input_delay_);
    if (result.wait_frames > 0) {
        ++stats_.time_sync_waits;
        stats_.time_sync_wait_frames += static_cast<std::uint64_t>(result.wait_frames);
    }
    result.tick_stretch_ppm = FramePacing::tick_stretch_ppm(frames_ahead_x100());
    return result;
}

int SessionImpl::catch_up_impl(std::uint64_t now_us, int max_frames) {
    if (phase_ != SessionPhase::Running) return 0;
    int stepped = 0;
    const bool spectator = config_.role == Role::Spectator;
    while (stepped < max_frames && behind(now_us) > 1) {
        sync_->rollback_if_needed();
        confirm_frames();
        if (spectator ? sync_->frame() >= sync_->inputs_complete() : sync_->must_wait(input_delay_)) break;
        if (!spectator && sync_->frame() >= count_of(config_.local_player)) break;  // our own input is due first
        if (sync_->frame() >= last_frame_) break;
        sync_->step_forward();
        confirm_frames();
        ++stepped;
    }
    if (stats_.oversized_states > 0) fail(SessionEvent::Reason::StateTooLarge, oversized_message(sim_), now_us);
    return stepped;
}

std::uint32_t SessionImpl::checkpoint() const {
    const std::uint32_t newest = detector_->newest_local();
    return newest - newest % static_cast<std::uint32_t>(config_.checksum_interval);
}

void SessionImpl::poll_handshake(std::uint64_t now_us) {
    maybe_start(now_us);  // alone at start (every other slot absent): nothing to wait for
    handshake_.poll_hellos(links_, phase_, scene_checksum_, now_us, pending_out_);
    const bool newcomer = config_.role != Role::Player;
    const bool syncing = phase_ == SessionPhase::Synchronizing || phase_ == SessionPhase::Transferring;
    // A joiner cut off from a majority says so, as a player does; so does a restarted player
    // before frame 0, once a running slot told it that it restarted (rollback/joiner_reach.h).
    if (config_.role != Role::Spectator && syncing) {
        reach_.begin(now_us);
        if (reach_.judges(config_.role)) changes_.joiner_cut_off(reach_.judge(config_, now_us), now_us);
    }
    // Asking for a snapshot: a newcomer once some running peer has welcomed it enough times (and
    // the others had a moment to answer), a desynced peer from the majority peer it picked.
    const bool recovering = phase_ == SessionPhase::Running && recover_from_.has_value();
    if (!(newcomer && syncing) && !recovering) return;
    if (!fetch_.may_ask(now_us)) return;
    std::vector<PlayerId> ask;
    if (recovering) ask.push_back(*recover_from_);
    else fetch_.newcomer_providers(links_, handshake_.first_welcome_us(), now_us, ask);
    if (ask.empty()) return;
    fetch_.ask(ask, recovering ? TransferReason::Recover
                               : (config_.role == Role::Spectator ? TransferReason::Spectate : TransferReason::Join),
               now_us, pending_out_);
}

void SessionImpl::poll_transfer(std::uint64_t now_us) {
    switch (fetch_.poll(now_us, pending_out_)) {
        case SnapshotFetch::Poll::Decided: return finish_transfer(now_us);
        case SnapshotFetch::Poll::TimedOut:
            // A provider that went silent (or crawls): start over with whoever answers.
            emit(SessionEvent::Kind::SnapshotRejected, SessionEvent::Reason::TransferTimedOut, fetch_.provider(), fetch_.incoming()->offer().frame, now_us,
                 fetch_.why() + "; asking again");
            return fetch_.restart();
        case SnapshotFetch::Poll::Nothing: return;
    }
}

// Who may be served and which offer goes out are JoinHandoff's (rollback/join_handoff.h); what
// the session does about it -- sending, events, the resend floor -- stays here (Effects,
// rollback/session_effects.h).
void SessionImpl::handle_snapshot_request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us) {
    const JoinState state{config_, membership_, *sync_, server_, links_, slots_, stats_.peers, replies_this_poll_,
                          phase_ == SessionPhase::Running};
    JoinHandoff(state, *effects_).request(from, m, now_us);
}

void SessionImpl::handle_snapshot_offer(PlayerId from, const SnapshotOfferMessage& m, std::uint64_t now_us) {
    const bool newcomer_waiting = config_.role != Role::Player &&
                                  (phase_ == SessionPhase::Synchronizing || phase_ == SessionPhase::Transferring);
    const bool recovering = phase_ == SessionPhase::Running && recover_from_ == from && m.reason == TransferReason::Recover;
    if (!newcomer_waiting && !recovering) return void(++stats_.peers[from].ignored_packets);
    switch (fetch_.take_offer(from, m, now_us)) {
        case SnapshotFetch::OfferTaken::Busy: return;  // one transfer at a time
        case SnapshotFetch::OfferTaken::TooLarge:
            return fail(SessionEvent::Reason::OfferTooLarge, "snapshot offer of " + std::to_string(m.size) + " bytes exceeds the limit of " +
                            std::to_string(config_.max_snapshot_bytes),
                        now_us);
        case SnapshotFetch::OfferTaken::BadSlotTable: return malformed(from, "snapshot offer: slot table size");
        case SnapshotFetch::OfferTaken::Started:
            if (config_.role == Role::Joiner && newcomer_waiting) reach_.saw_view(m.slots);
            if (phase_ == SessionPhase::Synchronizing) phase_ = SessionPhase::Transferring;
            return;
    }
}

void SessionImpl::handle_snapshot_chunk(PlayerId from, const SnapshotChunkMessage& m, std::uint64_t now_us) {
    if (!fetch_.take_chunk(from, m)) return void(++stats_.peers[from].ignored_packets);
    if (fetch_.complete()) finish_transfer(now_us);
}

void SessionImpl::finish_transfer(std::uint64_t now_us) {
    SnapshotFetch::Result got;
    const auto verdict =
        fetch_.finish(now_us, links_, [&](std::span<const std::uint8_t> state) { return sim_.checksum(state); }, got);
    if (verdict == SnapshotFetch::Verdict::Pending) return;
    const PlayerId from = got.from;
    const SnapshotOfferMessage& offer = got.offer;
    const TransferContents& t = got.contents;
    const auto reject = [&](SessionEvent::Reason reason, const std::string& why) {
        emit(SessionEvent::Kind::SnapshotRejected, reason, from, offer.frame, now_us, why + "; asking again");
    };
    if (verdict == SnapshotFetch::Verdict::Rejected) {
        reach_.named_silent(got.silent);
        return reject(SessionEvent::Reason::TransferInvalid, got.why);
    }
    // The fetch forgot the transfer: a failed load asks again like any rejection.
    if (std::string e = sync_->load_transfer(t); !e.empty()) return reject(SessionEvent::Reason::TransferLoadFailed, "snapshot transfer: " + e);
    authority_->reset_all();
    detector_->restart_at(t.frame, sim_.checksum(t.state));
    pacing_.restart_at(t.frame);
    for (auto& link : links_) link.time_sync().clear();
    if (offer.reason == TransferReason::Recover) {
        ++recoveries_;
        recover_from_.reset();
        mismatch_frame_.reset();
        emit(SessionEvent::Kind::DesyncRecovered, recovery_reason_, from, t.frame, now_us,
             "this peer was " + recovery_why_ + "; reloaded peer " + std::to_string(from) + "'s confirmed frame " +
                 std::to_string(t.frame));
        refresh_resend_floor();
        return;
    }
    JoinHandoff::take_view(offer, membership_, slots_, links_, now_us);
    if (config_.role == Role::Joiner) {
        changes_.joiner_cut_off({}, now_us);  // loaded on a majority's word: it reached one
        joining_ = true;
        own_inputs_from_ = offer.handoff_frame;
        links_[from].remote_ack = 0;
    }
    phase_ = SessionPhase::Running;
    started_us_ = now_us;
    emit(SessionEvent::Kind::SnapshotLoaded,
         config_.role == Role::Joiner ? SessionEvent::Reason::Joining : SessionEvent::Reason::Spectating, from, t.frame,
         now_us,
         (config_.role == Role::Joiner ? "own inputs from frame " + std::to_string(offer.handoff_frame) : "spectating") +
             "; " + got.why);
    emit(SessionEvent::Kind::Synchronized, SessionEvent::Reason::FromSnapshot, config_.local_player, t.frame, now_us,
         "from a snapshot");
    refresh_resend_floor();
}

// After narrowing (or a few seconds), decide who is odd: the peers whose checksum of the first
// mismatching frame is in the minority reload the majority's state; a tie between two groups
// (always so with two players) keeps the group of the lowest (or highest) slot.
// What to do about a mismatch is next_recovery_step's (rollback/recovery_source.h).
void SessionImpl::consider_recovery(std::uint64_t now_us) {
    if (config_.max_recoveries == 0 || !mismatch_frame_ || recover_from_ || config_.role == Role::Spectator) return;
    const std::uint32_t f = *mismatch_frame_;
    std::vector<std::pair<PlayerId, std::optional<std::uint64_t>>> peers;
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        if (!live_peer(pid)) continue;
        const auto theirs = detector_->remote_checksum(pid, f);
        // Not told (its messages of that time were lost: a one-way cut): asked for it, or the
        // 5 s rule would leave out a live peer and a tie could keep the odd one.
        if (!theirs) detector_->ask_checksum(pid, f);
        peers.emplace_back(pid, theirs);
    }
    RecoveryCase c;
    c.me = config_.local_player;
    c.mine = detector_->local_checksum(f);
    c.peers = peers;
    for (std::size_t p = 0; p < links_.size(); ++p) c.investigating = c.investigating || detector_->investigating(static_cast<PlayerId>(p));
    c.mismatch_since_us = mismatch_since_us_;
    c.now_us = now_us;
    c.recoveries = recoveries_;
    c.max_recoveries = config_.max_recoveries;
    c.keep = config_.two_player_keep;
    const RecoveryStep step = next_recovery_step(c);
    switch (step.act) {
        case RecoveryStep::Act::Wait: return;
        case RecoveryStep::Act::Forget: return mismatch_frame_.reset();
        case RecoveryStep::Act::GiveUp:
            return fail(SessionEvent::Reason::RecoveryLimit,
                        "desync at frame " + std::to_string(f) + " and the recovery limit (" +
                            std::to_string(config_.max_recoveries) + ") is reached",
                        now_us);
        case RecoveryStep::Act::Reload:
            recover_from_ = step.from;
            // Which rule made this peer the odd one, for its DesyncRecovered (issue 21: with two
            // players no majority exists, and the tie rule decided).
            recovery_reason_ = step.tie ? SessionEvent::Reason::TieRule : SessionEvent::Reason::Majority;
            recovery_why_ = std::string(step.tie ? "on a tie's other side" : "in the minority") + " at frame " +
                            std::to_string(f) + ", by " + step.rule;
            fetch_.ask_again();  // reported once, as DesyncDetected; DesyncRecovered says who was odd and why
            return;
    }
}

StreamView SessionImpl::stream_view() const {
    return {config_, membership_, sync_->queues(), *authority_, slots_, links_, sync_->confirmed_frame(), input_delay_, joining_,
            &changes_.agreement()};
}

void SessionImpl::poll_impl(std::uint64_t now_us, std::vector<Datagram>& out) {
    last_now_us_ = std::max(last_now_us_, now_us);
    const auto account = [&](const Datagram& d) {
        ++stats_.packets_sent;
        stats_.bytes_sent += d.bytes.size();
        ++stats_.peers[d.peer].packets_sent;
        stats_.peers[d.peer].bytes_sent += d.bytes.size();
    };
    if (phase_ != SessionPhase::Failed) {
        poll_handshake(now_us);
        poll_transfer(now_us);
    }
    for (Datagram& d : pending_out_) {
        account(d);
        out.push_back(std::move(d));
    }
    pending_out_.clear();
    std::fill(replies_this_poll_.begin(), replies_this_poll_.end(), 0);
    if (phase_ != SessionPhase::Running) return;

    queries_.clear();
    detector_->collect_queries(now_us, queries_);
    for (const auto& [peer, q] : queries_) {
        if (!live_peer(peer)) continue;
        Datagram d{peer, {}, false};
        encode(q, d.bytes);
        account(d);
        out.push_back(std::move(d));
    }

    const bool spectator = config_.role == Role::Spectator;
    const std::size_t n = config_.input_size;
    const std::uint32_t cp = checkpoint();
    const StreamRelay relay(stream_view());
    const bool lagging = relay.lags_on_a_stream();
    for (std::size_t p = 0; p < links_.size(); ++p) {
        const auto pid = static_cast<PlayerId>(p);
        PeerLink& link = links_[p];
        if (!live_peer(pid)) continue;
        if (spectator && !link.welcomed) continue;
        InputMessage& m = out_msg_;
        m.has_extension = false;
        m.has_agreement = false;
        m.slots.clear();
        m.blocks.clear();
        m.ack = is_slot(pid) ? static_cast<std::uint16_t>(relay.owner_count(pid)) : 0;
        std::uint32_t count = 0;
        m.inputs.clear();
        if (!spectator) {
            // Our inputs it has not acknowledged (a joiner's from its handoff frame on).
            const auto run = sync_->queue(config_.local_player)
                                 .copy_confirmed(std::max(link.remote_ack, own_inputs_from_), max_frames_per_message(n), m.inputs);
            count = run.count;
            m.first_frame = static_cast<std::uint16_t>(run.first);
        }
        m.frame_count = static_cast<std::uint8_t>(count);
        m.has_time_sync = link.messages_sent % static_cast<std::uint64_t>(config_.time_sync_every) == 0;
        m.sender_frame = static_cast<std::uint16_t>(sync_->frame());
        m.advantage = clamp_i8(local_advantage_[p]);
        const PeerLink::Stamps st = link.outgoing_stamps(now_us);
        m.stamp = st.stamp;
        m.echo = st.echo;
        m.hold = st.hold;
        // Every checkpoint confirmed since the last message (newest three at most), else the
        // newest again until it has ridden checksum_repeats messages. Players only: spectators
        // compare nothing with anyone.
        m.checksum_count = spectator || !is_slot(pid)
                               ? 0
                               : link.pick_checksums(cp, static_cast<std::uint32_t>(config_.checksum_interval), config_.checksum_repeats,
                                                     kMaxChecksumsPerMessage, [&](std::uint32_t f) { return detector_->local_checksum(f); },
                                                     m.checksum_frames, m.checksums);
        relay.table_entries_for(pid, table_entries_);
        if (relay.extension_needed(pid, table_entries_, now_us, lagging)) {
            const std::size_t base = 6 + std::size_t{count} * (1 + n) + 9 + 6 * std::size_t{m.checksum_count};
            relay.fill_extension(pid, m, kMaxDatagramBytes > base ? kMaxDatagramBytes - base : 0, now_us);
            link.table_sent(table_entries_, now_us, kTableCopies);
        }
        ++link.messages_sent;
        Datagram d{pid, {}, false};
        encode(m, n, d.bytes);
        account(d);
        out.push_back(std::move(d));
    }
}

void SessionImpl::set_prediction_window(int frames) { sync_->set_prediction_window(frames); }

void SessionImpl::set_input_delay(int frames) {
    const int max_delay = static_cast<int>(config_.input_capacity / 4);
    if (frames < 0 || frames > max_delay)
        throw std::invalid_argument("input delay must be 0.." + std::to_string(max_delay));
    input_delay_ = frames;
}

void SessionImpl::damage_outgoing_chunks(int count, ChunkDamage how) { server_.damage(count, how); }

}  // namespace lockroll::rollback
