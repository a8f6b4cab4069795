#include "net/peer_runner.h"

#include <algorithm>
#include <stdexcept>

#include "net/clock.h"
#include "net/tick_schedule.h"
#include "rollback/protocol.h"

namespace lockroll::net {

namespace {
// Reliable datagrams kept per unconnected peer (the newest; the session re-asks what is lost).
constexpr std::size_t kMaxHeldPerPeer = 64;
}  // namespace

const char* outcome_name(RunOutcome o) {
    switch (o) {
        case RunOutcome::Completed: return "completed";
        case RunOutcome::ConnectTimeout: return "connect_timeout";
        case RunOutcome::FinishTimeout: return "finish_timeout";
        case RunOutcome::RunTimeout: return "run_timeout";
        case RunOutcome::Failed: return "failed";
        case RunOutcome::Stopped: return "stopped";
        case RunOutcome::Partitioned: return "partitioned";
        case RunOutcome::ServerLost: return "server_lost";
    }
    return "?";
}

PeerRunner::PeerRunner(const RunnerConfig& config, rollback::Session& session, transport::Transport& transport,
                       InputSource input, RunnerObserver* observer)
    : RunnerBase(config, transport, std::move(input), observer), session_(session) {
    const auto& sc = session_.config();
    if (config_.catch_up_frames < 0) throw std::invalid_argument("RunnerConfig: catch_up_frames must be >= 0");
    if (transport_.local_id() != sc.local_player)
        throw std::invalid_argument("PeerRunner: the transport's local_id() is " + std::to_string(transport_.local_id()) +
                                    ", the session's local player is " + std::to_string(sc.local_player));
    const auto ids = static_cast<std::size_t>(sc.players + sc.max_spectators);
    for (const auto& p : config_.peers)
        if (p.slot >= ids || session_.host_of(p.slot) == sc.local_player || session_.host_of(p.slot) != p.slot)
            throw std::invalid_argument("RunnerConfig: peer id " + std::to_string(p.slot) +
                                        " is out of range, local, or a slot played by another slot's process");
    connected_.assign(ids, false);
    held_.assign(ids, {});
    redial_ = RedialBackoff(ids);
    // One input per local slot (several players on one machine: SessionConfig::slot_hosts).
    input_bytes_.assign(std::max<std::size_t>(session_.local_slots().size(), 1) * sc.input_size, 0);
    // A run of target_frame frames shows frame target_frame last: while it lingers for the last
    // confirmations and acknowledgements, the session rolls back and confirms but steps no further.
    session_.set_last_frame(config_.target_frame);
}

std::uint64_t PeerRunner::started_us() const { return loop_->started_us(); }

void PeerRunner::track_connections(std::uint64_t now) {
    for (transport::TransportEvent e; transport_.next_event(e);) {
        if (e.peer < connected_.size()) {
            if (e.type == transport::TransportEvent::Type::Connected) {
                connected_[e.peer] = true;
                redial_.heard(e.peer);  // lost again later: redialed at once, then backing off
                // Control messages the session sent before the connection existed (snapshot
                // requests and chunks; never hellos, see tick()): deliver them now, in order.
                for (const auto& bytes : held_[e.peer]) transport_.send_reliable(e.peer, bytes, now);
                held_[e.peer].clear();
            }
            if (e.type == transport::TransportEvent::Type::Disconnected) connected_[e.peer] = transport_.is_connected(e.peer);
        }
        if (observer_) observer_->on_transport_event(e, now);
    }
}

bool PeerRunner::service(std::uint64_t now) {
    transport_.poll(now);
    track_connections(now);
    // The lower id connects, one connection per pair: no crossed connects, also when a killed
    // slot comes back (the lower survivors keep retrying it, it retries the higher ones).
    // Spectators have the highest ids but nobody knows their addresses: they connect to everyone.
    // connect() refuses harmlessly while a connection exists or is pending. A peer that stays
    // away is dialed ever less often, up to a cap (net/redial_backoff.h), never given up; a dial
    // connect() refused (the last attempt still pending) is not charged, so the attempt that
    // fails is followed at once by a new one.
    const auto& sc = session_.config();
    const bool spectator = sc.role == rollback::Role::Spectator;
    for (const auto& p : config_.peers)
        if ((spectator || p.slot > sc.local_player) && !transport_.is_connected(p.slot))
            redial_.try_dial(p.slot, now, [&] { return transport_.connect(p.slot, p.host, p.port); });
    return all_connected();
}

// Without a handshake the runner is the start barrier: every remote process connected.
bool PeerRunner::all_connected() const {
    const auto& sc = session_.config();
    if (sc.handshake) return true;  // the session waits for its peers itself (hellos resent)
    for (int p = 0; p < sc.players; ++p) {
        const auto id = static_cast<rollback::PlayerId>(p);
        // Slots played by another slot's process have no connection of their own.
        if (id != sc.local_player && session_.host_of(id) == id && !connected_[static_cast<std::size_t>(p)]) return false;
    }
    return true;
}

bool PeerRunner::everyone_confirmed() const {
    const std::uint32_t target = config_.target_frame;
    if (session_.confirmed_frame() < target) return false;
    const auto& sc = session_.config();
    // A spectator sends no inputs: nobody needs anything from it.
    if (sc.role == rollback::Role::Spectator) return true;
    // Players wait for players only: spectators get the last inputs from the resends while the
    // players linger, and are bounded by their own finish timeout.
    for (int p = 0; p < sc.players; ++p) {
        const auto id = static_cast<rollback::PlayerId>(p);
        if (id == sc.local_player) continue;
        // Dropped or absent slots and peers without a connection are not waited for.
        if (session_.slot_state(id) != rollback::SlotState::Running || !connected_[static_cast<std::size_t>(p)]) continue;
        if (session_.peer_ack(id) < target) return false;
    }
    return true;
}

void PeerRunner::drain_session_events() {
    using K = rollback::SessionEvent::Kind;
    const auto& sc = session_.config();
    for (rollback::SessionEvent e; session_.next_event(e);) {
        // An episode still open keeps its first frame: a session the majority dropped reports
        // Partitioned again as a joiner (rollback/joiner_reach.h) while still cut off.
        if (e.kind == K::Partitioned && !partitioned_since_) {
            partitioned_since_ = e.frame;
            confirmed_while_partitioned_ = session_.confirmed_frame();
        }
        alone_.saw(e, sc.players);
        // A slot handed over to a joiner (the owner's word or its table's) has a process back at
        // its address: dial it at once if we are the side that dials, whatever our backoff from
        // its old one had grown to (issue 21: slot 1 reached a rejoining slot 2 only at its next
        // dial, 4 s on, and the joiner's snapshot was refused as cut off from a majority).
        if (e.kind == K::Joined && e.peer < connected_.size() && !connected_[e.peer]) redial_.heard(e.peer);
        if (e.kind == K::SnapshotLoaded && rejoined_ && !rejoined_->at_frame) rejoined_->at_frame = e.frame;
        // Dropped by the others: not an end but a rejoin, once this drain is over (the session
        // decides whether it can: rollback/rejoin.h). The failure it caused is not one; the drop
        // is news only to a game that saw the session play.
        if (e.kind == K::Kicked && config_.rejoin_when_dropped && session_.can_rejoin()) {
            rejoining_ = true;
            if (!ran_) continue;
        }
        if (e.kind == K::Failed && rejoining_) continue;
        events_.push_back(e);
        if (observer_) observer_->on_session_event(e);
    }
    // Alone whenever a drop left this process the only running voter of its view (the two-player
    // rule, in a match of two or one shrunk to two): rollback/playing_alone.h decides.
    alone_.settle(rollback::running_voters(session_), sc.local_player);
    if (rejoining_) rejoin();
}

// The session starts again in place as a joiner of its slot (Session::restart_as_joiner): the
// same transport, connections and schedule; it says hello, loads the majority's snapshot and
// catches up in the ticks that follow.
void PeerRunner::rejoin() {
    rejoining_ = false;
    RejoinRecord r;
    r.partitioned_since = partitioned_since_;
    r.dropped_at_frame = session_.frame();
    if (!session_.restart_as_joiner()) return;
    rejoined_ = r;
}

// Whether the partition episode is still open after this tick. Not just Session::partitioned():
// a minority the majority dropped stops being partitioned when it hears the first of them again
// (its votes withdrawn), a tick or more before their refusals make it kicked; that kick must still
// say it came out of a partition. So an episode ends only once the session, no longer cut off,
// confirms frames again (which a dropped minority never does).
bool PeerRunner::track_partition() {
    // The event gives the frame; should it have been lost (a full event queue), the session's
    // state still opens the episode, at its confirmed frame as the event would have said.
    if (!partitioned_since_ && session_.partitioned()) partitioned_since_ = session_.confirmed_frame();
    if (!partitioned_since_) return false;
    if (session_.partitioned()) {
        confirmed_while_partitioned_ = std::max(confirmed_while_partitioned_, session_.confirmed_frame());
        return true;
    }
    if (session_.phase() != rollback::SessionPhase::Failed && session_.confirmed_frame() > confirmed_while_partitioned_) {
        partitioned_since_.reset();
        return false;
    }
    return true;
}

std::uint32_t PeerRunner::tick(std::uint64_t now, std::uint64_t scheduled) {
    while (transport_.receive(in_, now)) {
        if (in_.from >= connected_.size()) continue;
        session_.receive(static_cast<rollback::PlayerId>(in_.from), in_.bytes, in_.time_us);
    }
    const std::uint32_t input_frame = session_.frame() + static_cast<std::uint32_t>(session_.input_delay());
    input_(input_frame, input_bytes_);
    TickReport report;
    report.tick = ticks_;
    report.now_us = now;
    report.scheduled_us = scheduled;
    report.advance = session_.advance(input_bytes_, now);
    ran_ = ran_ || session_.running();
    // Only a joiner catches up by stepping faster (it starts behind, from a snapshot); players
    // that drift apart are evened out by time sync.
    if (config_.catch_up_frames > 0 && session_.config().role == rollback::Role::Joiner && session_.running() &&
        session_.behind(now) > 0)
        session_.catch_up(now, config_.catch_up_frames);
    drain_session_events();
    // Time sync by a slightly longer tick. The session's per-tick stretch is the advice; a
    // wait_frames recommendation alone (sessions without it) becomes a debt repaid the same way,
    // a newer one replacing the unpaid rest (it measures the whole gap as it stands).
    const auto max_extra = static_cast<std::uint64_t>(static_cast<double>(period_us_) * config_.max_stretch);
    std::uint64_t extra = 0;
    if (report.advance.tick_stretch_ppm > 0) {
        debt_us_ = 0;
        extra = std::min(max_extra, period_us_ * static_cast<std::uint64_t>(report.advance.tick_stretch_ppm) / 1000000u);
    } else {
        if (report.advance.wait_frames > 0) debt_us_ = static_cast<std::uint64_t>(report.advance.wait_frames) * period_us_;
        extra = std::min(debt_us_, max_extra);
        debt_us_ -= extra;
    }
    stretch_.record(extra);
    out_.clear();
    session_.poll(now, out_);
    send_polled(now, [this](const rollback::Datagram& d) {
        // Not a hello: it carries its send time for the round trip, so one held until the
        // connection is up would count the wait as network time (seconds, for a peer that
        // starts late); the session says hello again every hello_resend_us until welcomed.
        if (d.peer >= held_.size() || rollback::peek_kind(d.bytes) == rollback::MessageKind::Hello) return;
        auto& held = held_[d.peer];
        if (held.size() >= kMaxHeldPerPeer) held.pop_front();
        held.push_back(d.bytes);
    });
    return report_tick(report, extra);
}

TickStatus PeerRunner::status() {
    return TickStatus{.failed = session_.phase() == rollback::SessionPhase::Failed,
                      .running = session_.running(),
                      .shown_target = session_.frame() >= config_.target_frame,
                      .confirmed = everyone_confirmed(),
                      .partitioned = track_partition()};
}

}  // namespace lockroll::net
