#include "server/relay_room.h"

#include <algorithm>
#include <cmath>

#include "rollback/arbitration.h"

namespace lockroll::server {

using namespace lockroll::rollback;

namespace {
// Frames of inputs a slot may send ahead of the confirmed frame (ring size).
constexpr std::uint32_t kWindow = 512;

std::uint16_t stamp_hold(std::uint64_t since_us, std::uint64_t now_us) {
    return static_cast<std::uint16_t>(std::min<std::uint64_t>(0xFFFF, (now_us - since_us) / 100));
}
}  // namespace

RelayRoom::RelayRoom(std::uint64_t id, const RelayHello& first, const RoomConfig& config)
    : id_(id),
      config_(config),
      players_(first.players),
      input_size_(first.input_size),
      tick_rate_(first.tick_rate),
      scene_checksum_(first.scene_checksum),
      absent_at_start_(first.absent_slots),
      period_us_(1000000u / std::max<unsigned>(1, first.tick_rate)),
      max_frames_(relay_max_frames(first.players, first.input_size)),
      history_(static_cast<std::size_t>(first.players) * (1 + first.input_size),
               static_cast<std::size_t>(std::min(std::max(1.0, config.history_s * first.tick_rate), 1e9))) {

    slots_.resize(static_cast<std::size_t>(players_));
    for (auto& s : slots_) {
        s.last_input.assign(input_size_, 0);
        s.pending.assign(kWindow * input_size_, 0);
        s.pending_frame.assign(kWindow, 0);
    }
    spectators_.resize(static_cast<std::size_t>(std::max(0, config.max_spectators)));
}

bool RelayRoom::matches(const RelayHello& h) const {
    return h.players == players_ && h.input_size == input_size_ && h.tick_rate == tick_rate_ &&
           h.scene_checksum == scene_checksum_ && h.absent_slots == absent_at_start_;
}

std::uint32_t RelayRoom::clock_frame(std::uint64_t now_us) const {
    if (!started_ || now_us < start_us_) return 0;
    return static_cast<std::uint32_t>((now_us - start_us_) * static_cast<std::uint64_t>(tick_rate_) / 1000000u);
}

int RelayRoom::slot_of(ConnectionId c) const {
    for (int s = 0; s < players_; ++s)
        if (slots_[static_cast<std::size_t>(s)].connected && slots_[static_cast<std::size_t>(s)].client.connection == c) return s;
    for (std::size_t i = 0; i < spectators_.size(); ++i)
        if (spectators_[i].connected && spectators_[i].client.connection == c) return players_ + static_cast<int>(i);
    return -1;
}

std::uint16_t RelayRoom::slots_of(int primary) const {
    std::uint16_t mask = 0;
    for (int s = 0; s < players_; ++s) {
        const Slot& sl = slots_[static_cast<std::size_t>(s)];
        if (sl.connected && sl.primary == primary) mask = static_cast<std::uint16_t>(mask | (1u << s));
    }
    return mask;
}

std::uint16_t RelayRoom::connection_slots(ConnectionId c) const {
    const int id = slot_of(c);
    return id >= 0 && id < players_ ? slots_of(id) : 0;
}

bool RelayRoom::holder(int slot, ConnectionId& c) const {
    if (slot < 0 || slot >= players_ || !slots_[static_cast<std::size_t>(slot)].connected) return false;
    c = slots_[static_cast<std::size_t>(slot)].client.connection;
    return true;
}

bool RelayRoom::live(ConnectionId c, std::uint64_t now_us) const {
    const int id = slot_of(c);
    if (id < 0) return false;
    const Client& cl = id < players_ ? slots_[static_cast<std::size_t>(id)].client
                                     : spectators_[static_cast<std::size_t>(id - players_)].client;
    return now_us - cl.last_heard_us < config_.replace_silent_us;
}

RelayRoom::Client* RelayRoom::client(int id) {
    if (id < 0) return nullptr;
    if (id < players_) {
        auto& s = slots_[static_cast<std::size_t>(id)];
        return s.connected ? &slots_[s.primary].client : nullptr;
    }
    const auto i = static_cast<std::size_t>(id - players_);
    if (i >= spectators_.size() || !spectators_[i].connected) return nullptr;
    return &spectators_[i].client;
}

bool RelayRoom::empty() const {
    for (const auto& s : slots_)
        if (s.connected) return false;
    for (const auto& s : spectators_)
        if (s.connected) return false;
    return true;
}

int RelayRoom::snapshot_source(int except) const {
    for (int s = 0; s < players_; ++s) {
        const auto& slot = slots_[static_cast<std::size_t>(s)];
        if (s != except && is_primary(s) && slot.state == SlotState::Running && slot.client.ack > 0) return s;
    }
    return kNoSlot;
}

void RelayRoom::send_welcome(ConnectionId c, int id, RelayRefusal r, std::uint64_t echo_us, std::uint64_t now_us,
                             Outbox& out) {
    RelayWelcome w;
    w.refusal = r;
    w.players = static_cast<std::uint8_t>(players_);
    w.input_size = static_cast<std::uint8_t>(input_size_);
    w.tick_rate = static_cast<std::uint16_t>(tick_rate_);
    w.checksum_interval = static_cast<std::uint16_t>(config_.checksum_interval);
    w.input_deadline = static_cast<std::uint8_t>(config_.input_deadline);
    w.echo_us = echo_us;
    w.started = started_;
    w.server_frame = clock_frame(now_us);
    if (r == RelayRefusal::None) {
        w.slot = static_cast<std::uint8_t>(id);
        // A newcomer to a running room pulls a snapshot from the lowest connected player.
        w.snapshot_from = started_ && id_joined_late(id) ? static_cast<std::uint8_t>(snapshot_source(id)) : kNoSlot;
        if (id < players_) w.handoff_frame = slots_[static_cast<std::size_t>(id)].input_from;
    }
    encode(w, out.add(c, true).bytes);
}

bool RelayRoom::id_joined_late(int id) const {
    if (id >= players_) return spectators_[static_cast<std::size_t>(id - players_)].late;
    return slots_[static_cast<std::size_t>(id)].late;
}

void RelayRoom::welcome_again(ConnectionId c, const RelayHello& h, std::uint64_t now_us, Outbox& out) {
    const int id = slot_of(c);
    if (id >= 0) send_welcome(c, id, RelayRefusal::None, h.stamp_us, now_us, out);
}

RelayRefusal RelayRoom::admit(ConnectionId c, const RelayHello& h, std::uint64_t now_us, Outbox& out,
                              ConnectionId* replaced) {
    auto refuse = [&](RelayRefusal r) {
        send_welcome(c, -1, r, h.stamp_us, now_us, out);
        return r;
    };
    if (!matches(h)) return refuse(RelayRefusal::RoomParams);

    Client fresh;
    fresh.connection = c;
    fresh.last_heard_us = now_us;
    fresh.ack = started_ ? confirmed_next_ : 0;
    if (h.role == RelayRole::Spectator) {
        auto it = std::find_if(spectators_.begin(), spectators_.end(), [](const Spectator& s) { return !s.connected; });
        if (it == spectators_.end()) return refuse(RelayRefusal::Full);
        it->connected = true;
        it->late = started_;
        it->client = fresh;
        send_welcome(c, players_ + static_cast<int>(it - spectators_.begin()), RelayRefusal::None, h.stamp_us, now_us, out);
        return RelayRefusal::None;
    }
    const std::uint16_t want = relay_hello_slots(h);
    if (h.slot >= players_ || (want >> players_) != 0) return refuse(RelayRefusal::BadSlot);
    if (want & banned_) return refuse(RelayRefusal::Kicked);
    // Every slot is judged before any is bound: the hello is admitted whole or not at all.
    // A slot is resumed (the same process: its incarnation), free, or held by a connection that
    // is silent (a restarted process takes it over); at most one such connection per hello.
    ConnectionId other = 0;
    bool has_other = false;
    for (int p = 0; p < players_; ++p) {
        if (!(want & (1u << p))) continue;
        const Slot& s = slots_[static_cast<std::size_t>(p)];
        if (!s.connected || s.client.connection == c) continue;
        if (has_other && other != s.client.connection) return refuse(RelayRefusal::SlotTaken);
        other = s.client.connection;
        has_other = true;
        const bool resume = started_ && h.incarnation != 0 && h.incarnation == s.incarnation && s.state != SlotState::Absent;
        if (!resume && now_us - slots_[s.primary].client.last_heard_us < config_.replace_silent_us)
            return refuse(RelayRefusal::SlotTaken);
    }
    if (has_other) {
        if (replaced) *replaced = other;  // to be closed: its slots are this hello's now
        // Its slots this hello does not name leave with it.
        for (int p = 0; p < players_; ++p) {
            Slot& s = slots_[static_cast<std::size_t>(p)];
            if (s.connected && s.client.connection == other && !(want & (1u << p))) release(s);
        }
    }
    bool late = false;
    for (int p = 0; p < players_; ++p) {
        if (!(want & (1u << p))) continue;
        Slot& s = slots_[static_cast<std::size_t>(p)];
        s.primary = h.slot;
        // The same process on a new connection (its transport reconnected): it keeps its slot,
        // its stream and its state; no snapshot. The incarnation is the client's secret token.
        if (started_ && h.incarnation != 0 && h.incarnation == s.incarnation && s.state != SlotState::Absent) {
            const bool was_running = s.state == SlotState::Running;
            s.connected = true;
            s.client = fresh;
            s.state = SlotState::Running;
            if (!was_running) {  // it had left: its inputs count again from a little ahead
                s.input_from = std::max(confirmed_next_, clock_frame(now_us)) + static_cast<std::uint32_t>(config_.handoff_ticks);
                std::fill(s.pending_frame.begin(), s.pending_frame.end(), 0);
                s.awaiting_handoff = true;
                s.lapsed = false;
            }
            continue;
        }
        s.connected = true;
        s.client = fresh;
        s.incarnation = h.incarnation;
        s.counters.minority_streak = 0;  // a new process: the old one's verdicts are not its own
        late = late || started_;
        const bool was_running = s.state == SlotState::Running;
        s.state = SlotState::Running;
        s.awaiting_handoff = started_;
        s.lapsed = false;
        if (!started_) {
            s.input_from = 0;
        } else {
            // Its inputs count from a little ahead of the clock, so the snapshot, the catch-up and
            // the first input's trip fit before then; frames until then are absent (a join) or
            // replaced (a reconnect whose slot was still running).
            const std::uint32_t from = std::max(confirmed_next_, clock_frame(now_us)) +
                                       static_cast<std::uint32_t>(config_.handoff_ticks);
            s.input_from = was_running ? std::max(s.input_from, from) : from;
            if (!was_running) s.last_input.assign(input_size_, 0);
        }
        std::fill(s.pending_frame.begin(), s.pending_frame.end(), 0);
    }
    // One process, one state: if any of its slots is new to a running room, it begins from a
    // snapshot (a resumed slot's state is the process's own, which the snapshot replaces).
    for (int p = 0; p < players_; ++p)
        if (want & (1u << p)) slots_[static_cast<std::size_t>(p)].late = late;
    send_welcome(c, h.slot, RelayRefusal::None, h.stamp_us, now_us, out);
    if (!started_) {
        bool all = true;
        for (int i = 0; i < players_; ++i)
            if (!(absent_at_start_ & (1u << i)) && !slots_[static_cast<std::size_t>(i)].connected) all = false;
        if (all) start(now_us);
    }
    return RelayRefusal::None;
}

void RelayRoom::start(std::uint64_t now_us) {
    started_ = true;
    start_us_ = now_us;
    next_tick_us_ = now_us;
    for (auto& s : slots_)
        if (s.connected) s.client.last_heard_us = now_us;
}

bool RelayRoom::has_input(const Slot& s, std::uint32_t frame) const {
    return s.pending_frame[frame % kWindow] == frame + 1;
}

const std::uint8_t* RelayRoom::input_at(const Slot& s, std::uint32_t frame) const {
    return &s.pending[(frame % kWindow) * input_size_];
}

std::uint32_t RelayRoom::input_ack(const Slot& s) const {
    std::uint32_t f = std::max(confirmed_next_, s.input_from);
    const std::uint32_t end = confirmed_next_ + kWindow;
    while (f < end && has_input(s, f)) ++f;
    return f;
}

void RelayRoom::confirm_one(std::uint64_t now_us) {
    (void)now_us;
    const std::uint32_t f = confirmed_next_;
    const std::span<std::uint8_t> rec = history_.push();
    std::uint8_t* inputs = rec.data() + players_;
    for (int p = 0; p < players_; ++p) {
        Slot& s = slots_[static_cast<std::size_t>(p)];
        std::uint8_t* dst = inputs + static_cast<std::size_t>(p) * input_size_;
        if (plays_absent(s, f)) {
            rec[static_cast<std::size_t>(p)] = kRelayAbsent;
        } else if (has_input(s, f)) {
            std::copy_n(input_at(s, f), input_size_, dst);
            std::copy_n(dst, input_size_, s.last_input.begin());
            s.pending_frame[f % kWindow] = 0;
        } else {
            rec[static_cast<std::size_t>(p)] = kRelayReplaced;
            std::copy_n(s.last_input.begin(), input_size_, dst);
            ++s.counters.replaced;
        }
    }
    ++confirmed_next_;
}

void RelayRoom::confirm_ready(std::uint64_t now_us) {
    const std::uint32_t before = confirmed_next_;
    const std::uint32_t clock = clock_frame(now_us);
    const auto deadline = static_cast<std::uint32_t>(config_.input_deadline);
    for (;;) {
        const std::uint32_t f = confirmed_next_;
        bool ready = true, anyone = false;
        for (const auto& s : slots_) {
            if (plays_absent(s, f)) continue;
            anyone = true;
            if (!has_input(s, f)) {
                ready = false;
                break;
            }
        }
        // Nobody waits on a late slot past the deadline; and never beyond the clock otherwise
        // (a room where nobody plays confirms nothing ahead of time).
        const bool due = started_ && clock >= f + deadline;
        if (!(due || (ready && anyone))) break;
        confirm_one(now_us);
    }
    if (confirmed_next_ != before) {
        frames_pending_ = true;
        pending_now_us_ = now_us;
    }
}

void RelayRoom::send_pending(Outbox& out) {
    if (!frames_pending_) return;
    frames_pending_ = false;
    broadcast(pending_now_us_, false, out);
}

void RelayRoom::send_frames(Client& cl, std::uint32_t ack, std::uint64_t now_us, Outbox& out) {
    RelayFrames& m = frames_;
    const std::uint64_t ticks = started_ && now_us >= start_us_ ? (now_us - start_us_) * static_cast<std::uint64_t>(tick_rate_) : 0;
    m.server_frame = static_cast<std::uint32_t>(ticks / 1000000u);
    m.server_subframe = static_cast<std::uint16_t>((ticks % 1000000u) * 65536u / 1000000u);
    m.input_ack = ack;
    m.players = static_cast<std::uint8_t>(players_);
    m.input_size = static_cast<std::uint8_t>(input_size_);
    const std::uint32_t from = std::max(cl.ack, history_base());
    const std::uint32_t count = std::min<std::uint32_t>(confirmed_next_ > from ? confirmed_next_ - from : 0, max_frames_);
    m.first_frame = from;
    m.frame_count = static_cast<std::uint16_t>(count);
    m.stamp = static_cast<std::uint16_t>(now_us / 100);
    m.echo = cl.has_stamp ? cl.stamp : 0;
    m.hold = cl.has_stamp ? stamp_hold(cl.stamp_at_us, now_us) : 0xFFFF;
    // Straight from the history (records of flags then inputs: the message's layout per frame).
    struct Source {
        const FrameHistory* history;
        std::size_t first;
    } source{&history_, from - history_base()};
    encode_frames(
        m, &source,
        [](const void* c, std::uint32_t i) {
            const auto* s = static_cast<const Source*>(c);
            return s->history->at(s->first + i).data();
        },
        out.add(cl.connection, false).bytes);
    cl.last_send_us = now_us;
}

std::uint32_t RelayRoom::connection_input_ack(int primary) const {
    // Its records carry all its slots together: it needs to resend from the first any lacks.
    std::uint32_t ack = ~std::uint32_t{0};
    for (int p = primary; p < players_; ++p)
        if (slots_[static_cast<std::size_t>(p)].connected && slots_[static_cast<std::size_t>(p)].primary == primary)
            ack = std::min(ack, input_ack(slots_[static_cast<std::size_t>(p)]));
    return ack;
}

void RelayRoom::broadcast(std::uint64_t now_us, bool only_if_due, Outbox& out) {
    for (int p = 0; p < players_; ++p) {
        if (!is_primary(p)) continue;  // one Frames message per connection
        Slot& s = slots_[static_cast<std::size_t>(p)];
        if (only_if_due && now_us - s.client.last_send_us < period_us_) continue;
        send_frames(s.client, connection_input_ack(p), now_us, out);
    }
    for (auto& sp : spectators_) {
        if (!sp.connected) continue;
        if (only_if_due && now_us - sp.client.last_send_us < period_us_) continue;
        send_frames(sp.client, 0, now_us, out);
    }
}

void RelayRoom::tick(std::uint64_t now_us, Outbox& out) {
    if (!started_ || now_us < next_tick_us_) return;
    next_tick_us_ += period_us_;
    if (next_tick_us_ <= now_us) next_tick_us_ = now_us + period_us_;
    lapse_handoffs(now_us);
    confirm_ready(now_us);
    send_pending(out);
    broadcast(now_us, true, out);
    // Checksum rounds whose missing reports are not coming (a client left or lags).
    while (!checks_.empty() &&
           checks_.front().frame + static_cast<std::uint32_t>(config_.checksum_timeout_frames) < confirmed_next_) {
        decide(checks_.front(), out);
        checks_.pop_front();
    }
}

void RelayRoom::lapse_handoffs(std::uint64_t now_us) {
    // The same wait as a silent connection's, counted from the frame its inputs were due.
    const std::uint64_t lapse = config_.silence_drop_us * static_cast<std::uint64_t>(tick_rate_) / 1000000u;
    const std::uint64_t clock = clock_frame(now_us);
    for (auto& s : slots_)
        if (s.state == SlotState::Running && s.awaiting_handoff && !s.lapsed && clock >= s.input_from + lapse)
            s.lapsed = true;
}

void RelayRoom::notify_all(const RelayNotice& n, Outbox& out) {
    std::vector<std::uint8_t> bytes;
    encode(n, bytes);
    for (int p = 0; p < players_; ++p)
        if (is_primary(p)) out.add(slots_[static_cast<std::size_t>(p)].client.connection, true).bytes = bytes;
    for (auto& s : spectators_)
        if (s.connected) out.add(s.client.connection, true).bytes = bytes;
}

void RelayRoom::silent_connections(std::uint64_t now_us, std::vector<ConnectionId>& out) const {
    for (int p = 0; p < players_; ++p) {
        const Slot& s = slots_[static_cast<std::size_t>(p)];
        if (is_primary(p) && now_us - s.client.last_heard_us >= config_.silence_drop_us) out.push_back(s.client.connection);
    }
    for (const auto& s : spectators_)
        if (s.connected && now_us - s.client.last_heard_us >= config_.silence_drop_us) out.push_back(s.client.connection);
}

void RelayRoom::remove(ConnectionId c, std::uint64_t now_us) {
    (void)now_us;
    const int id = slot_of(c);
    if (id < 0) return;
    if (id < players_) {
        for (auto& s : slots_)
            if (s.connected && s.client.connection == c) release(s);
    } else {
        spectators_[static_cast<std::size_t>(id - players_)].connected = false;
    }
}

void RelayRoom::release(Slot& s) {
    s.connected = false;
    s.primary = kNoSlot;
    // Before the start a slot simply frees up; after it, its stream turns absent from the
    // next frame to confirm (until someone rejoins it).
    s.state = started_ ? SlotState::Left : SlotState::Absent;
    std::fill(s.pending_frame.begin(), s.pending_frame.end(), 0);
}

const char* RelayRoom::receive(ConnectionId c, std::span<const std::uint8_t> d, std::uint64_t now_us,
                               Outbox& out) {
    const int id = slot_of(c);
    Client* cl = client(id);
    if (!cl) return "relay: connection not in this room";
    cl->last_heard_us = now_us;
    const auto kind = peek_relay_kind(d);
    if (!kind) return "relay: unknown message kind";
    if (*kind == RelayKind::Forward) {
        if (const char* e = decode(d, fwd_)) return e;
        Client* to = client(fwd_.slot);
        if (fwd_.slot == id || (to && to->connection == cl->connection)) return "relay forward: to itself";
        if (!to) {
            // Its snapshot source left: name another (if any), and the requester asks it.
            RelayNotice n;
            n.kind = RelayNoticeKind::Snapshot;
            n.slot = static_cast<std::uint8_t>(snapshot_source(id));
            if (n.slot == kNoSlot) return nullptr;
            encode(n, out.add(cl->connection, true).bytes);
            return nullptr;
        }
        RelayForward back;
        back.slot = static_cast<std::uint8_t>(id);
        back.payload = std::move(fwd_.payload);
        encode(back, out.add(to->connection, true).bytes);
        return nullptr;
    }
    if (*kind != RelayKind::Input) return "relay: unexpected message kind from a client";
    if (const char* e = decode(d, input_size_, in_)) return e;
    // The slots come from the connection: records for any other set (another's slot, a slot
    // more or less) are not this connection's to author. The whole message is ignored.
    const std::uint16_t mine = id < players_ ? slots_of(id) : 0;
    if (in_.frame_count > 0 && in_.slots != mine) return "relay input: slots this connection was not admitted for";
    if (in_.confirmed_ack == kRelayNoFrames) cl->ack = confirmed_next_;  // the clock only, for now
    else if (in_.confirmed_ack > confirmed_next_) return "relay input: acknowledges frames not confirmed";
    else cl->ack = std::max(in_.confirmed_ack, history_base());
    cl->stamp = in_.stamp;
    cl->stamp_at_us = now_us;
    cl->has_stamp = true;
    const char* problem = nullptr;
    if (id < players_ && in_.frame_count > 0) {
        const std::size_t count = static_cast<std::size_t>(relay_slot_count(mine));
        const std::uint64_t clock_limit = started_ ? std::uint64_t{clock_frame(now_us)} + static_cast<std::uint64_t>(config_.max_frames_ahead)
                                                   : static_cast<std::uint64_t>(config_.max_frames_ahead);
        const std::uint64_t limit = std::min<std::uint64_t>(clock_limit, std::uint64_t{confirmed_next_} + kWindow);
        auto out_of_window = [&](const char* why) {
            for (int p = id; p < players_; ++p)
                if (mine & (1u << p)) ++slots_[static_cast<std::size_t>(p)].counters.out_of_window;
            problem = why;
        };
        for (std::uint32_t i = 0; i < in_.frame_count; ++i) {
            const std::uint64_t f = std::uint64_t{in_.first_frame} + i;
            if (f >= limit) {
                out_of_window("relay input: frame out of window");
                break;
            }
            const auto frame = static_cast<std::uint32_t>(f);
            // An honest client resends its inputs from the oldest it has not seen confirmed, which
            // lags the room by its round trip (seconds under a loss burst), never by a whole
            // input window: older frames are bad, not resends.
            if (std::uint64_t{frame} + kWindow < confirmed_next_) {
                out_of_window("relay input: frame far in the past");
                break;
            }
            // The record's inputs, one per slot of the connection, in slot order.
            std::size_t k = 0;
            for (int p = id; p < players_; ++p) {
                if (!(mine & (1u << p))) continue;
                Slot& s = slots_[static_cast<std::size_t>(p)];
                const auto at = static_cast<std::ptrdiff_t>((i * count + k++) * input_size_);
                if (frame < std::max(confirmed_next_, s.input_from)) {
                    if (frame < confirmed_next_ && frame >= history_base() &&
                        (history_.at(frame - history_base())[static_cast<std::size_t>(p)] & kRelayReplaced))
                        ++s.counters.late;
                    continue;
                }
                if (has_input(s, frame)) continue;
                if (s.lapsed) {
                    // Its handoff starts after all: its inputs count from this frame (the ones
                    // before it, confirmed or not, stay absent).
                    s.input_from = frame;
                    s.lapsed = false;
                }
                s.awaiting_handoff = false;
                std::copy_n(in_.inputs.begin() + at, input_size_,
                            s.pending.begin() + static_cast<std::ptrdiff_t>((frame % kWindow) * input_size_));
                s.pending_frame[frame % kWindow] = frame + 1;
                ++s.counters.inputs;
            }
        }
    }
    if (id < players_)
        for (int i = 0; i < in_.checksum_count; ++i) {
            const std::uint32_t f = in_.checksum_frames[i];
            // Frame f is the state after f steps: confirmed once frames [0, f) are, so f may
            // equal confirmed_next_ (a client reports it as soon as the frames message arrives).
            if (config_.checksum_interval <= 0 || f % static_cast<std::uint32_t>(config_.checksum_interval) != 0 ||
                f > confirmed_next_)
                return "relay input: checksum of a frame not confirmed or not a checkpoint";
            report_checksum(id, f, in_.checksums[i], now_us, out);
        }
    confirm_ready(now_us);
    return problem;
}

void RelayRoom::report_checksum(int slot, std::uint32_t frame, std::uint64_t value, std::uint64_t now_us,
                                Outbox& out) {
    (void)now_us;
    auto it = std::find_if(checks_.begin(), checks_.end(), [&](const Check& c) { return c.frame == frame; });
    if (it == checks_.end()) {
        // Rounds already decided (older than the oldest open one) are not reopened.
        if (!checks_.empty() && frame < checks_.front().frame) return;
        if (!decided_.empty() && frame <= decided_.back()) return;
        if (checks_.size() >= kMaxPendingChecks) {
            decide(checks_.front(), out);
            checks_.pop_front();
        }
        Check c;
        c.frame = frame;
        it = std::upper_bound(checks_.begin(), checks_.end(), frame, [](std::uint32_t f, const Check& x) { return f < x.frame; });
        it = checks_.insert(it, c);
    }
    it->value[static_cast<std::size_t>(slot)] = value;
    it->have |= 1u << slot;
    std::uint32_t need = 0;
    // One vote per connection: its lowest slot's (a connection's slots share one state).
    for (int p = 0; p < players_; ++p)
        if (is_primary(p) && slots_[static_cast<std::size_t>(p)].state == SlotState::Running) need |= 1u << p;
    if ((it->have & need) == need) {
        decide(*it, out);
        checks_.erase(it);
    }
}

void RelayRoom::decide(Check& c, Outbox& out) {
    decided_.push_back(c.frame);
    if (decided_.size() > kMaxPendingChecks) decided_.pop_front();
    if (ended_without_majority_) return;  // the match is over: nothing left to settle
    int running = 0;
    for (int p = 0; p < players_; ++p)
        if (is_primary(p) && slots_[static_cast<std::size_t>(p)].state == SlotState::Running) ++running;
    // The value most slots report; on a tie, the one of the lowest slot among the tied values;
    // two disagreeing voters alone under EndMatch: nobody (rollback/arbitration.h, P2P's rule).
    const rollback::ArbitrationRule rule{rollback::ArbitrationTie::LowestSlot,
                                         config_.two_player_desync == TwoPlayerDesync::EndMatch};
    const rollback::ArbitrationVerdict verdict = rollback::arbitrate(c.value, c.have, running, rule);
    if (verdict.no_majority) {
        // Neither can be shown wrong: reloading one from the other would let a liar make its
        // honest peer reload for ever. Both are told, and the match ends for both.
        ended_without_majority_ = true;
        for (int p = 0; p < players_; ++p) {
            if (!(c.have & (1u << p))) continue;
            Slot& s = slots_[static_cast<std::size_t>(p)];
            ++s.counters.desyncs;
            verdicts_.emplace_back(c.frame, p);
            if (!s.connected) continue;
            RelayNotice n;
            n.kind = RelayNoticeKind::Desync;
            n.slot = rollback::kRelayNoMajority;
            n.frame = c.frame;
            n.detail = c.value[static_cast<std::size_t>(p)];
            encode(n, out.add(s.client.connection, true).bytes);
        }
        return;
    }
    const std::uint64_t best = verdict.value;
    const int voters = verdict.voters;
    const bool strict_majority = verdict.strict_majority;
    int source = kNoSlot;
    for (int p = 0; p < players_; ++p)
        if (verdict.is_winner(p) && slots_[static_cast<std::size_t>(p)].connected) {
            source = p;
            break;
        }
    for (int p = 0; p < players_; ++p) {
        if (!(c.have & (1u << p))) continue;
        Slot& s = slots_[static_cast<std::size_t>(p)];
        if (verdict.is_winner(p)) {
            s.counters.minority_streak = 0;
            continue;
        }
        ++s.counters.desyncs;
        verdicts_.emplace_back(c.frame, p);
        if (!s.connected) continue;
        // A persistent liar is outvoted round after round; an honest client that drifted once
        // reloads and agrees at the next round.
        if (voters >= 3 && strict_majority && config_.max_minority_rounds > 0 &&
            ++s.counters.minority_streak >= static_cast<std::uint32_t>(config_.max_minority_rounds)) {
            s.counters.minority_streak = 0;
            // Told why before the server closes the connection (the notice is queued first,
            // and ENet sends queued packets before a disconnect_later).
            RelayNotice k;
            k.kind = RelayNoticeKind::Kicked;
            k.slot = static_cast<std::uint8_t>(p);
            k.frame = c.frame;
            encode(k, out.add(s.client.connection, true).bytes);
            for (int q = 0; q < players_; ++q)
                if (slots_[static_cast<std::size_t>(q)].connected &&
                    slots_[static_cast<std::size_t>(q)].client.connection == s.client.connection)
                    banned_ |= static_cast<std::uint16_t>(1u << q);
            kicks_.push_back(s.client.connection);
            continue;
        }
        RelayNotice n;
        n.kind = RelayNoticeKind::Desync;
        n.slot = static_cast<std::uint8_t>(source);
        n.frame = c.frame;
        n.detail = best;
        encode(n, out.add(s.client.connection, true).bytes);
    }
}

void RelayRoom::take_kicks(std::vector<ConnectionId>& out) {
    out.insert(out.end(), kicks_.begin(), kicks_.end());
    kicks_.clear();
}

bool RelayRoom::confirmed_inputs(std::uint32_t frame, std::vector<std::uint8_t>& flags, std::vector<std::uint8_t>& inputs) const {
    if (frame >= confirmed_next_ || frame < history_base()) return false;
    const auto rec = history_.at(frame - history_base());
    flags.assign(rec.begin(), rec.begin() + players_);
    inputs.assign(rec.begin() + players_, rec.end());
    return true;
}

std::size_t RelayRoom::bytes_reserved() const {
    std::size_t n = history_.bytes_reserved();
    for (const auto& sl : slots_) n += sl.pending.capacity() + sl.pending_frame.capacity() * sizeof(std::uint32_t) + sl.last_input.capacity();
    return n;
}

}  // namespace lockroll::server
