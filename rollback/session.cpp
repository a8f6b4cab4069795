#include "rollback/session_impl.h"

#include "rollback/input_authority.h"
#include "rollback/frame_pacing.h"
#include "rollback/handshake.h"
#include "rollback/input_delay.h"
#include "rollback/input_frames.h"
#include "rollback/recovery_source.h"
#include "rollback/rejoin.h"
#include "rollback/session_admission.h"

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

constexpr int kMaxChunksPerPoll = 64;
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
        s_.emit(SessionEvent::Kind::DesyncDetected, e.peer, e.frame, s_.last_now_us_,
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

// The rest of the session as the membership changes and the authored streams see it.
class SessionImpl::Effects final : public MembershipEffects, public AuthoringEffects {
public:
    explicit Effects(SessionImpl& s) : s_(s) {}
    void emit(SessionEvent::Kind kind, PlayerId peer, std::uint32_t frame, std::uint64_t now_us, std::string detail) override {
        s_.emit(kind, peer, frame, now_us, std::move(detail));
    }
    void fail_dropped(std::uint64_t now_us) override { s_.fail(drop_failure(s_.config_), now_us); }
    void slot_changed_hands(PlayerId slot) override { s_.authority_->reset_slot(slot); }
    void peer_failed(PlayerId peer) override { s_.detector_->peer_failed(peer); }
    void peer_replaced(PlayerId peer) override { s_.detector_->reset_peer(peer); }
    void live_peers_changed() override { s_.refresh_resend_floor(); }
    bool live_peer(PlayerId peer) const override { return s_.live_peer(peer); }
    std::uint32_t frame() const override { return s_.frame(); }
    std::uint32_t confirmed_frame() const override { return s_.confirmed_frame(); }
    const InputQueue& stream(PlayerId slot) const override { return s_.sync_->queue(slot); }
    InputQueue::Add write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input, bool absent) override {
        return s_.sync_->add_remote_input(slot, frame, input, absent);
    }

private:
    SessionImpl& s_;
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
        if (link.hear(now_us)) emit(SessionEvent::Kind::Resumed, from, frame(), now_us);
        // Heard again: our vote that it is gone is withdrawn (a partition healed). A kick stays.
        if (is_slot(from) && !slots_[from].kick_vote && !slots_[from].lapsed) membership_.vote_local(from, false);
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
            return handle_input(from, now_us);
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

void SessionImpl::handle_hello(PlayerId from, const HelloMessage& m, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    WelcomeMessage w;
    w.match_id = config_.match_id;
    w.scene_checksum = scene_checksum_;
    w.echo_us = m.stamp_us;
    w.running = phase_ == SessionPhase::Running;
    if (is_slot(from)) w.slot_epoch = membership_.epoch(from);
    HelloContext c;
    c.match_id = config_.match_id;
    c.scene_checksum = scene_checksum_;
    c.from = from;
    c.from_slot = is_slot(from);
    c.running = phase_ == SessionPhase::Running;
    c.welcomed = link.welcomed;
    c.incarnation = link.incarnation;
    if (c.from_slot) {
        c.slot_running = slot_running(from);
        c.welcomed_in_this_epoch = link.welcomed_epoch == membership_.epoch(from);
        c.handed_off_by_me = slots_[from].handed_off_by_me;
        c.silent_us = now_us > link.last_heard_us ? now_us - link.last_heard_us : 0;
        c.interrupt_us = config_.interrupt_us;
    }
    const HelloAdmission a = admit_hello(m, c);
    w.refusal = a.refusal;
    const std::string& why = a.why;
    // Another process for a slot whose process we know and hear no more: it restarted. Our vote
    // that the old one is gone; welcome a joiner once a majority dropped it. A player is refused
    // as dropped in the drop's epoch (newer than its view's, so its vote counts there and it
    // rejoins), and asked to retry until then.
    if (a.restarted) {
        if (!changes_.claim_restart(from, m.role == Role::Player, now_us)) w.refusal = Refusal::Retry;
        w.slot_epoch = membership_.epoch(from);
    }
    if ((w.refusal != Refusal::None && w.refusal != Refusal::Retry) || a.doubted) {
        ++foreign_packets_;
        if (link.refusal_quiet_for(now_us, 1000000))
            emit(SessionEvent::Kind::Refused, from, frame(), now_us, "refused hello: " + why);
    }
    if (w.refusal == Refusal::None) {
        const bool fresh = !link.welcomed || link.role != m.role ||
                           (is_slot(from) && m.role == Role::Joiner && !slot_running(from) &&
                            link.welcomed_epoch != membership_.epoch(from));
        if (fresh && m.role != Role::Player) {
            // A new process for this id: forget everything about the previous one.
            link.reset_lifecycle(static_cast<std::size_t>(config_.players));
            link.clear_error();
            detector_->reset_peer(from);
        }
        link.accept_hello(m.role, m.incarnation, is_slot(from) ? std::optional(membership_.epoch(from)) : std::nullopt, now_us);
    }
    if (w.refusal != Refusal::None) {
        if (w.refusal != Refusal::Retry && !link.refusal_quiet_for(now_us, 100000)) return;
        link.mark_refusal(now_us);
    }
    std::vector<std::uint8_t> b;
    encode(w, b);
    send_control(from, std::move(b));
}

void SessionImpl::handle_welcome(PlayerId from, const WelcomeMessage& m, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    if (m.refusal == Refusal::Retry) return;
    if (m.refusal == Refusal::Disconnected) {
        if (config_.role == Role::Spectator) {
            emit(SessionEvent::Kind::Kicked, config_.local_player, frame(), now_us,
                 "peer " + std::to_string(from) + " says this spectator was dropped");
            fail(drop_failure(config_), now_us);
        } else if (config_.role == Role::Player || phase_ == SessionPhase::Running) {
            // The sender's vote that our slot is gone (in the epoch it dropped it into): one
            // voice, which makes us Kicked only together with a majority.
            if (is_slot(from)) changes_.count_vote(from, config_.local_player, Vote::Gone, m.slot_epoch);
            changes_.settle_membership(now_us);
        }
        return;
    }
    if (m.refusal != Refusal::None) {
        std::string why = std::string("peer ") + std::to_string(from) + " refused: " + refusal_name(m.refusal);
        if (m.refusal == Refusal::MatchId)
            why += " (theirs " + std::to_string(m.match_id) + ", ours " + std::to_string(config_.match_id) + ")";
        if (m.refusal == Refusal::Scene)
            why += " (theirs " + std::to_string(m.scene_checksum) + ", ours " + std::to_string(scene_checksum_) + ")";
        emit(SessionEvent::Kind::Refused, from, frame(), now_us, why);
        if (phase_ != SessionPhase::Running) fail(why, now_us);
        return;
    }
    if (phase_ == SessionPhase::Running) return welcomed_while_running(from, m, now_us);
    if (phase_ != SessionPhase::Synchronizing && phase_ != SessionPhase::Transferring) return;
    handshake_.sync_welcome(link, is_slot(from), m, now_us);
    if (m.echo_us <= now_us) stats_.peers[from].rtt_us = link.rtt_us();
    if (m.running) link.role = is_slot(from) ? Role::Player : Role::Spectator;
    emit(SessionEvent::Kind::Synchronizing, from, static_cast<std::uint32_t>(link.roundtrips), now_us);
    maybe_start(now_us);
}

// A joiner that loaded its snapshot from one peer may reach another only afterwards (between
// processes: that peer's connection came up late). Its hellos go on until every running slot
// has welcomed it; the late welcome makes the link live, so the two exchange inputs from now on
// (without it each would ignore the other and the peer would drop the slot for silence).
void SessionImpl::welcomed_while_running(PlayerId from, const WelcomeMessage& m, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    if (config_.role != Role::Joiner || !is_slot(from) || !slot_running(from) || !m.running || link.welcomed) return;
    link.late_welcome(membership_.epoch(from), m.echo_us, now_us);
    if (m.echo_us <= now_us) stats_.peers[from].rtt_us = link.rtt_us();
    emit(SessionEvent::Kind::Synchronizing, from, 1, now_us);
    refresh_resend_floor();
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
    emit(SessionEvent::Kind::Synchronized, config_.local_player, frame(), now_us,
         "input delay " + std::to_string(input_delay_) + ", worst sync rtt " + std::to_string(worst / 1000) + " ms");
}

void SessionImpl::handle_input(PlayerId from, std::uint64_t now_us) {
    const InputMessage& m = in_msg_;
    PeerLink& link = links_[from];
    const bool from_player = is_slot(from);
    const bool i_play = config_.role != Role::Spectator;
    const PlayerId me = config_.local_player;
    // Unwrap every frame before applying anything, so a bad packet changes nothing.
    InputReferences refs;
    refs.from_player = from_player;
    refs.takes_ack = from_player && i_play;
    refs.our_count = i_play ? count_of(me) : 0;
    refs.its_count = from_player ? count_of(from) : 0;
    refs.frame = sync_->frame();
    refs.newest_checksum = detector_->newest_local();
    refs.players = config_.players;
    InputFrames frames;
    if (const char* e = unwrap_input(m, refs, frames)) return malformed(from, e);
    const auto& [ack, first, sender_frame, checksum_frames] = frames;

    if (ack && link.take_ack(*ack)) refresh_resend_floor();
    if (first) {
        const std::size_t n = config_.input_size;
        for (std::uint32_t k = 0; k < m.frame_count; ++k) {
            const std::uint32_t f = *first + k;
            const auto in = std::span(m.inputs).subspan(k * n, n);
            const auto r = sync_->add_remote_input(from, f, in);
            if (!owner_copy(from, f, in, r)) return malformed(from, "input message: rewrites a confirmed input");
            if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;  // resent later
        }
    }
    if (m.has_extension) {
        apply_slot_table(from, now_us);
        if (phase_ == SessionPhase::Failed) return;
        apply_blocks(from);
    }
    if (sender_frame) {
        // An honest peer is never farther from us than input delay plus prediction window (plus
        // the time sync's own slack); a claim beyond that is clipped, so one forged message
        // cannot make us wait thousands of frames.
        const std::int64_t bound = pacing_.advantage_bound(input_delay_);
        link.note_remote_frame(*sender_frame, clamp_i8(std::clamp<std::int64_t>(m.advantage, -bound, bound)), now_us);
        link.take_stamps(m.stamp, m.echo, m.hold, now_us);
    }
    for (int i = 0; i < m.checksum_count; ++i) detector_->add_remote(from, checksum_frames[i], m.checksums[i]);
}

// The sender's table: its counts (relays, agreement), and its vote about every running slot.
// About a running slot, "disconnected" in a newer epoch is the sender's vote that it is gone and
// "running" in our epoch its vote that it runs; only a majority of such votes drops the slot
// (settle_membership). "Running" in a newer epoch is a hand-over to a new process (the owner's
// word, adopted as before), and so is any newer epoch of a slot that does not run here (a join,
// or a drop we missed). The sender's entries about itself and its guests say nothing new, and
// nobody but this session's own process hands over this session's slots.
void SessionImpl::apply_slot_table(PlayerId from, std::uint64_t now_us) {
    PeerLink& link = links_[from];
    for (const SlotEntry& e : in_msg_.slots) {
        const std::size_t s = e.slot;
        const auto count = unwrap_frame(e.count, count_of(e.slot));
        link.table[s] = e;
        link.table_seen[s] = true;
        link.counts_at_us = now_us;
        if (count) {
            link.counts[s] = *count;
            link.has_count[s] = true;
        }
        if (!is_slot(from)) continue;            // spectators report counts, never vote
        if (host_of(e.slot) == from) continue;   // a player's own entry says nothing new
        if (config_.role == Role::Spectator) {
            // A spectator follows the view of the players that serve it (they send it the view,
            // not their votes).
            if (newer_epoch(e.epoch, membership_.epoch(e.slot))) adopt_slot(e.slot, e, now_us);
            continue;
        }
        const bool mine = config_.role != Role::Spectator && (e.slot == config_.local_player || my_guest(e.slot));
        const bool newer = newer_epoch(e.epoch, membership_.epoch(e.slot));
        if (!slot_running(e.slot)) {
            if (newer && !mine) adopt_slot(e.slot, e, now_us);
        } else if (e.state == SlotState::Running && newer) {
            if (!mine) adopt_slot(e.slot, e, now_us);
        } else {
            count_vote(from, e.slot, e.state == SlotState::Running ? Vote::Runs : Vote::Gone, e.epoch);
        }
        if (phase_ == SessionPhase::Failed) return;
    }
    settle_membership(now_us);
    if (phase_ == SessionPhase::Failed) return;
    if (config_.role == Role::Spectator) return;
    // What the sender holds of our stream (a spectator or joiner reports it here).
    const PlayerId me = config_.local_player;
    if (link.has_count[me] && link.counts[me] > link.remote_ack && link.counts[me] <= count_of(me)) {
        link.remote_ack = link.counts[me];
        refresh_resend_floor();
    }
}

// Inputs of other slots' streams, forwarded by the sender. Accepted only for streams whose
// player is not the sender's connection itself (that is the base message's job) and, for a
// running slot, never from anyone while the slot's own process sends them: only gaps are filled,
// and a forwarded input that contradicts a confirmed one is a protocol violation like any other.
void SessionImpl::apply_blocks(PlayerId from) {
    const std::size_t n = config_.input_size;
    for (const StreamBlock& b : in_msg_.blocks) {
        if (is_slot(from) && b.slot == from) continue;
        if (config_.role != Role::Spectator && (b.slot == config_.local_player || my_guest(b.slot))) continue;
        const auto first = unwrap_frame(b.first_frame, count_of(b.slot));
        if (!first) continue;
        if (relayed_block(from, b, *first)) {
            if (phase_ == SessionPhase::Failed || links_[from].error()) return;
            continue;
        }
        for (std::uint32_t k = 0; k < b.frame_count; ++k) {
            const auto r = sync_->add_remote_input(b.slot, *first + k, std::span(b.inputs).subspan(k * n, n), b.absent);
            if (r == InputQueue::Add::Conflict) return malformed(from, "input message: relayed input contradicts a confirmed one");
            if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;
        }
        SlotView& v = slots_[b.slot];
        if (b.absent && !v.neutral_reported && !slot_running(b.slot)) {
            v.neutral_reported = true;
            // The first absent input of this epoch tells the agreed frame.
            std::uint32_t f = count_of(b.slot);
            const InputQueue& q = sync_->queue(b.slot);
            while (f > q.floor() && q.confirmed_absent(f - 1)) --f;
            emit(SessionEvent::Kind::NeutralFrom, b.slot, f, last_now_us_);
        }
    }
}

// Our stream is kept back to the oldest input a live peer has not acknowledged. With no live
// peer (every other slot dropped or absent, or a one-player match) nothing is owed to anyone:
// the floor stays "no limit", and only Sync's retain window holds inputs back. It must not be
// pinned to a frame instead (it was: confirmed_count() at the moment the last peer went): acks
// stop when nobody else is left, so a pinned floor never moved again and the local queue filled
// input_capacity frames later -- the lone survivor froze for good (issue 21). A peer that
// becomes live again (a joiner) counts from its own acks on; floors never move back, and what
// it lacks from before the floor comes with its snapshot.
void SessionImpl::refresh_resend_floor() {
    if (config_.role == Role::Spectator) return;
    std::uint32_t floor = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < links_.size(); ++p)
        if (live_peer(static_cast<PlayerId>(p))) floor = std::min(floor, links_[p].remote_ack);
    sync_->set_keep_from(config_.local_player, floor);
}

// Other streams are kept back to what a peer we may relay to still lacks, and while we serve a
// snapshot, from its frame. Never more than half the ring, so a peer that stops acknowledging
// cannot stall us: it is then beyond relaying and must fetch a snapshot.
void SessionImpl::refresh_keep_floors(std::uint64_t now_us) {
    for (int s = 0; s < config_.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (config_.role != Role::Spectator && slot == config_.local_player) continue;
        std::uint32_t keep = std::numeric_limits<std::uint32_t>::max();
        for (std::size_t p = 0; p < links_.size(); ++p) {
            const auto pid = static_cast<PlayerId>(p);
            PeerLink& l = links_[p];
            if (!live_peer(pid)) continue;
            if (l.pin_from && now_us > l.pin_until_us) l.pin_from.reset();
            if (l.pin_from) keep = std::min(keep, *l.pin_from);
            if (pid != slot && l.has_count[slot]) keep = std::min(keep, l.counts[slot]);
        }
        const std::uint32_t confirmed = sync_->confirmed_frame();
        const std::uint32_t lowest = confirmed > config_.input_capacity / 2 ? confirmed - config_.input_capacity / 2 : 0;
        sync_->set_keep_from(slot, std::max(keep, lowest));
    }
}

// The newest frame this session may confirm. Frame n is stepped from the inputs of frames
// before n, and ours among them must be held by a majority of the view (this session included;
// the others' acks say what they hold). So if that majority drops us while we cannot hear it (a
// partition), the neutral input it agrees on for our slot starts after every frame we confirmed,
// and nothing we confirmed can differ from what it confirmed (issue 21). Once we lose the
// majority, confirmation stops there. A view of two under PlayOnAlone needs nobody else. Never
// so far back that the state of the next frame to confirm is no longer saved.
std::uint32_t SessionImpl::confirm_limit() const {
    const std::uint32_t confirmable = sync_->confirmable_frame();
    const int others = membership_.majority_size() - 1;
    if (config_.role == Role::Spectator || others <= 0) return confirmable;
    std::array<std::uint32_t, kMaxPlayers> held{};
    int n = 0;
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        if (!live_peer(pid)) continue;
        const PeerLink& l = links_[pid];
        std::uint32_t h = l.remote_ack;
        for (std::size_t i = 1; i < local_slots_.size(); ++i) {
            const PlayerId g = local_slots_[i];  // our guests travel as blocks: the table's counts
            h = std::min(h, l.has_count[g] ? l.counts[g] : 0u);
        }
        held[static_cast<std::size_t>(n++)] = h;
    }
    std::uint32_t majority_holds = 0;
    if (n >= others) {
        std::nth_element(held.begin(), held.begin() + (others - 1), held.begin() + n, std::greater<>());
        majority_holds = held[static_cast<std::size_t>(others - 1)];
    }
    const auto span = static_cast<std::uint32_t>(config_.prediction_window + config_.evidence_frames / 2);
    const std::uint32_t oldest = sync_->frame() > span ? sync_->frame() - span : 0;
    // A relayed input of a running slot waits for its owner's own copy (which wins if it
    // differs), as long as the saved states allow: frame n rests on the inputs before n.
    const std::uint32_t unverified = authority_->first_unverified(sync_->confirmed_frame()).value_or(confirmable);
    return std::min(confirmable, std::max(std::min(majority_holds, unverified), oldest));
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
    NetworkStats n;
    if (p >= links_.size() || p == config_.local_player) return n;
    const PeerLink& l = links_[p];
    n.ping_us = l.rtt_us();
    n.jitter_us = l.rtt_var_us();
    const double seconds = now_us > started_us_ ? static_cast<double>(now_us - started_us_) / 1e6 : 0;
    if (seconds > 0) {
        n.kbps_sent = static_cast<double>(stats_.peers[p].bytes_sent) * 8 / 1000 / seconds;
        n.kbps_received = static_cast<double>(stats_.peers[p].bytes_received) * 8 / 1000 / seconds;
    }
    if (l.has_remote_frame) n.frames_behind = static_cast<std::int32_t>(std::int64_t{sync_->frame()} - l.estimated_frame(now_us, config_.interrupt_us, config_.tick_rate));
    if (config_.role != Role::Spectator) {
        const std::uint32_t sent = count_of(config_.local_player);
        n.send_queue = sent > l.remote_ack ? sent - l.remote_ack : 0;
    }
    n.interrupted = l.interrupted;
    return n;
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
    if (stats_.oversized_states > 0) fail(oversized_message(sim_), now_us);
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
    if (stats_.oversized_states > 0) fail(oversized_message(sim_), now_us);
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
            // A provider that went silent: start over with whoever answers.
            emit(SessionEvent::Kind::SnapshotRejected, fetch_.provider(), fetch_.incoming()->offer().frame, now_us,
                 "transfer timed out; asking again");
            return fetch_.restart();
        case SnapshotFetch::Poll::Nothing: return;
    }
}

void SessionImpl::handle_snapshot_request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us) {
    if (m.transfer_id != 0) {
        SnapshotChunkMessage c;
        switch (server_.chunk(from, m, c)) {
            case SnapshotServer::Chunk::NotOurs: return void(++stats_.peers[from].ignored_packets);
            case SnapshotServer::Chunk::OutOfRange: return malformed(from, "snapshot request: chunk out of range");
            case SnapshotServer::Chunk::Ready: break;
        }
        if (replies_this_poll_[from] >= kMaxChunksPerPoll) return void(++stats_.peers[from].ignored_packets);
        ++replies_this_poll_[from];
        server_.damage_next(c);
        std::vector<std::uint8_t> b;
        encode(c, b);
        send_control(from, std::move(b));
        return;
    }
    if (phase_ != SessionPhase::Running || config_.role == Role::Spectator) return;
    // A recovery is served only to a running player whose confirmed checksums this session has
    // seen differ from its own, and only when recoveries are on: a request is a claim, and
    // answering every one would turn a few bytes into a whole snapshot (an amplifier).
    if (m.reason == TransferReason::Recover &&
        (config_.max_recoveries == 0 || !is_slot(from) || !slot_running(from) || !detector_->desynced(from)))
        return void(++stats_.peers[from].ignored_packets);
    // The same peer asking again while its offer is young: the same offer (SnapshotServer).
    const SnapshotOfferMessage* repeat = nullptr;
    switch (server_.consider(from, m.reason, now_us, &repeat)) {
        case SnapshotServer::Ask::Repeat: {
            std::vector<std::uint8_t> b;
            encode(*repeat, b);
            return send_control(from, std::move(b));
        }
        case SnapshotServer::Ask::TooSoon: return void(++stats_.peers[from].ignored_packets);
        case SnapshotServer::Ask::Pack: break;
    }
    const std::uint32_t c = sync_->confirmed_frame();
    std::uint32_t handoff = 0;
    switch (m.reason) {
        case TransferReason::Join: {
            // Only the owner hands a slot over, and only once it writes the slot's neutral input
            // (the drop is agreed): it picks the handoff frame, far enough ahead that the
            // joiner's first input reaches everyone before they need it.
            if (!is_slot(from) || slot_running(from) || !slots_[from].authoring) return;
            // Its last handoff lapsed (check_handoff): not again before the backoff ends.
            if (now_us < slots_[from].next_handoff_us) return;
            handoff = std::max(count_of(from), local_target() + lead_frames(links_[from].rtt_us()));
            static const std::vector<std::uint8_t> zeros(kMaxInputSize, 0);
            while (count_of(from) < handoff)
                if (sync_->add_remote_input(from, count_of(from), std::span(zeros.data(), config_.input_size), true) !=
                    InputQueue::Add::Stored)
                    return;  // queue full: not now
            SlotView& v = slots_[from];
            membership_.set(from, SlotState::Running, static_cast<std::uint8_t>(membership_.epoch(from) + 1));
            v.new_epoch();
            v.handoff = handoff;
            v.handed_off_by_me = true;
            PeerLink& l = links_[from];
            l.reset_lifecycle(static_cast<std::size_t>(config_.players));
            l.welcomed = true;
            l.welcomed_epoch = membership_.epoch(from);
            l.mark_heard(now_us);
            detector_->reset_peer(from);
            emit(SessionEvent::Kind::Joined, from, handoff, now_us, "snapshot of frame " + std::to_string(c));
            break;
        }
        case TransferReason::Spectate:
            if (is_slot(from)) return;
            links_[from].reset_lifecycle(static_cast<std::size_t>(config_.players));
            links_[from].mark_heard(now_us);
            emit(SessionEvent::Kind::SpectatorJoined, from, c, now_us);
            break;
        case TransferReason::Recover:
            break;  // checked above
    }
    TransferContents t;
    if (!sync_->transfer_contents(c, true, t)) return;
    const std::size_t n = config_.input_size;
    // Old transfers go as this one is packed: bounded memory whatever newcomers ask.
    TransferSender::Transfer& out = server_.offer(from, m.reason, t, n, now_us);
    out.offer.handoff_frame = handoff;
    for (int s = 0; s < config_.players; ++s)
        out.offer.slots.push_back({static_cast<std::uint8_t>(s), slot_state(static_cast<PlayerId>(s)),
                                   membership_.epoch(static_cast<PlayerId>(s)), 0});
    // Keep what the newcomer will ask us for next: every stream from the snapshot on.
    PeerLink& l = links_[from];
    l.pin_from = c;
    l.pin_until_us = now_us + 30'000'000;
    if (config_.role != Role::Spectator && m.reason != TransferReason::Recover)
        l.remote_ack = count_of(config_.local_player);
    std::vector<std::uint8_t> b;
    encode(out.offer, b);
    send_control(from, std::move(b));
    refresh_resend_floor();
}

void SessionImpl::handle_snapshot_offer(PlayerId from, const SnapshotOfferMessage& m, std::uint64_t now_us) {
    const bool newcomer_waiting = config_.role != Role::Player &&
                                  (phase_ == SessionPhase::Synchronizing || phase_ == SessionPhase::Transferring);
    const bool recovering = phase_ == SessionPhase::Running && recover_from_ == from && m.reason == TransferReason::Recover;
    if (!newcomer_waiting && !recovering) return void(++stats_.peers[from].ignored_packets);
    switch (fetch_.take_offer(from, m, now_us)) {
        case SnapshotFetch::OfferTaken::Busy: return;  // one transfer at a time
        case SnapshotFetch::OfferTaken::TooLarge:
            return fail("snapshot offer of " + std::to_string(m.size) + " bytes exceeds the limit of " +
                            std::to_string(config_.max_snapshot_bytes),
                        now_us);
        case SnapshotFetch::OfferTaken::BadSlotTable: return malformed(from, "snapshot offer: slot table size");
        case SnapshotFetch::OfferTaken::Started:
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
    const auto reject = [&](const std::string& why) {
        emit(SessionEvent::Kind::SnapshotRejected, from, offer.frame, now_us, why + "; asking again");
    };
    if (verdict == SnapshotFetch::Verdict::Rejected) return reject(got.why);
    // The fetch forgot the transfer: a failed load asks again like any rejection.
    if (std::string e = sync_->load_transfer(t); !e.empty()) return reject("snapshot transfer: " + e);
    authority_->reset_all();
    detector_->restart_at(t.frame, sim_.checksum(t.state));
    pacing_.restart_at(t.frame);
    for (auto& link : links_) link.time_sync().clear();
    if (offer.reason == TransferReason::Recover) {
        ++recoveries_;
        recover_from_.reset();
        mismatch_frame_.reset();
        emit(SessionEvent::Kind::DesyncRecovered, from, t.frame, now_us,
             "reloaded peer " + std::to_string(from) + "'s confirmed frame " + std::to_string(t.frame));
        refresh_resend_floor();
        return;
    }
    for (const SlotEntry& e : offer.slots) {
        SlotView& v = slots_[e.slot];
        membership_.set(e.slot, e.state, e.epoch);
        v.new_epoch();  // a newcomer has handed nothing over
        v.neutral_reported = e.state != SlotState::Running;
    }
    for (auto& link : links_) {
        link.heard = link.welcomed;
        link.last_heard_us = now_us;
        link.interrupted = false;
    }
    if (config_.role == Role::Joiner) {
        joining_ = true;
        own_inputs_from_ = offer.handoff_frame;
        links_[from].remote_ack = 0;
    }
    phase_ = SessionPhase::Running;
    started_us_ = now_us;
    emit(SessionEvent::Kind::SnapshotLoaded, from, t.frame, now_us,
         (config_.role == Role::Joiner ? "own inputs from frame " + std::to_string(offer.handoff_frame) : "spectating") +
             "; " + got.why);
    emit(SessionEvent::Kind::Synchronized, config_.local_player, t.frame, now_us, "from a snapshot");
    refresh_resend_floor();
}

// After narrowing (or a few seconds), decide who is odd: the peers whose checksum of the first
// mismatching frame is in the minority reload the majority's state; a tie between two groups
// (always so with two players) keeps the group of the lowest (or highest) slot.
void SessionImpl::consider_recovery(std::uint64_t now_us) {
    if (config_.max_recoveries == 0 || !mismatch_frame_ || recover_from_ || config_.role == Role::Spectator) return;
    for (std::size_t p = 0; p < links_.size(); ++p)
        if (detector_->investigating(static_cast<PlayerId>(p)) && now_us < mismatch_since_us_ + 3'000'000) return;
    const std::uint32_t f = *mismatch_frame_;
    const auto mine = detector_->local_checksum(f);
    if (!mine) {
        mismatch_frame_.reset();
        return;
    }
    std::vector<std::pair<PlayerId, std::uint64_t>> theirs;
    for (int p = 0; p < config_.players; ++p) {
        const auto pid = static_cast<PlayerId>(p);
        if (!live_peer(pid)) continue;
        const auto value = detector_->remote_checksum(pid, f);
        if (!value) {
            if (now_us < mismatch_since_us_ + 5'000'000) return;  // wait for everyone's word
            continue;
        }
        theirs.emplace_back(pid, *value);
    }
    const auto source = recovery_source(config_.local_player, *mine, theirs, config_.two_player_keep);
    if (!source) {
        mismatch_frame_.reset();  // we are in the majority: the odd ones reload
        return;
    }
    if (recoveries_ >= config_.max_recoveries) {
        fail("desync at frame " + std::to_string(f) + " and the recovery limit (" + std::to_string(config_.max_recoveries) +
                 ") is reached",
             now_us);
        return;
    }
    recover_from_ = *source;
    fetch_.ask_again();
    emit(SessionEvent::Kind::DesyncDetected, *recover_from_, f, now_us,
         "this peer is in the minority; reloading peer " + std::to_string(*recover_from_) + "'s state");
}

StreamView SessionImpl::stream_view() const {
    return {config_, membership_, sync_->queues(), *authority_, slots_, links_, sync_->confirmed_frame(), input_delay_, joining_};
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

namespace lockroll::rollback {

// The owner's own input of `slot` at frame f came in (added: what the queue made of it). Equal to
// a relayed copy: verified. Different from a relayed copy: the owner wins -- its input replaces
// the relay's where no confirmed frame rests on it yet, and the relay is counted and ignored; if
// a confirmed frame already rests on it, it stands (the checksums tell; recovery repairs) and
// the owner is not blamed. False only when the owner contradicts an input nobody relayed: it
// rewrote its own past.
bool SessionImpl::owner_copy(PlayerId slot, std::uint32_t f, std::span<const std::uint8_t> input, InputQueue::Add added) {
    if (added == InputQueue::Add::Duplicate) authority_->verified(slot, f);
    if (added != InputQueue::Add::Conflict) return true;
    const auto relay = authority_->relay_of(slot, f);
    if (!relay) return false;
    const bool replaced = sync_->replace_remote_input(slot, f, input);
    if (authority_->owner_disagrees(slot, f, replaced) && *relay < stats_.peers.size())
        stats_.peers[*relay].relay_disagreements = authority_->disagreements(*relay);
    return true;
}

// A block of a running slot's stream, not from this session's own streams: its owner's (a host
// sends its guests' streams as blocks), or a relay's claim that fills only what the owner's
// stream has not delivered. True when handled here; false for every other block (absent
// streams, spectators' views), which apply_blocks takes as before.
bool SessionImpl::relayed_block(PlayerId from, const StreamBlock& b, std::uint32_t first) {
    if (config_.role == Role::Spectator || b.absent || !slot_running(b.slot)) return false;
    const std::size_t n = config_.input_size;
    const bool owner = is_slot(from) && host_of(b.slot) == from;
    if (!owner && authority_->ignored(from)) {
        ++stats_.peers[from].ignored_packets;
        return true;
    }
    for (std::uint32_t k = 0; k < b.frame_count; ++k) {
        const std::uint32_t f = first + k;
        const auto in = std::span(b.inputs).subspan(k * n, n);
        const auto r = sync_->add_remote_input(b.slot, f, in, false);
        if (owner) {
            if (!owner_copy(b.slot, f, in, r)) {
                malformed(from, "input message: rewrites a confirmed input of its guest");
                return true;
            }
        } else if (r == InputQueue::Add::Stored) {
            authority_->note_relayed(b.slot, f, from);
        } else if (r == InputQueue::Add::Duplicate) {
            authority_->vouch(b.slot, f, from);
        } else if (r == InputQueue::Add::Conflict) {
            // Against another relay's claim the owner decides later; against the owner's own
            // input this relay is wrong: counted and ignored, never a drop of the owner.
            if (!authority_->relay_of(b.slot, f)) {
                authority_->relay_disagrees(from);
                stats_.peers[from].relay_disagreements = authority_->disagreements(from);
            }
            return true;
        }
        if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;
    }
    return true;
}

}  // namespace lockroll::rollback

