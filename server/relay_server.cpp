#include "server/relay_server.h"

#include <algorithm>
#include <stdexcept>

namespace lockroll::server {

using namespace lockroll::rollback;

namespace {
std::uint64_t tag_key(const TokenTag& t) {
    std::uint64_t k = 0;
    for (int i = 0; i < 8; ++i) k |= static_cast<std::uint64_t>(t[static_cast<std::size_t>(i)]) << (8 * i);
    return k;
}
}  // namespace

const char* server_event_name(ServerEvent::Kind k) {
    switch (k) {
        case ServerEvent::Kind::RoomCreated: return "room_created";
        case ServerEvent::Kind::RoomStarted: return "room_started";
        case ServerEvent::Kind::RoomClosed: return "room_closed";
        case ServerEvent::Kind::Joined: return "joined";
        case ServerEvent::Kind::Left: return "left";
        case ServerEvent::Kind::Refused: return "refused";
        case ServerEvent::Kind::Kicked: return "kicked";
        case ServerEvent::Kind::Desync: return "desync";
        case ServerEvent::Kind::Throttled: return "throttled";
    }
    return "?";
}

void validate(const ServerConfig& c) {
    auto need = [](bool ok, const char* what) {
        if (!ok) throw std::invalid_argument(what);
    };
    need(c.room.input_deadline >= 1 && c.room.input_deadline <= 255, "input deadline must be 1..255 ticks");
    need(c.room.checksum_interval >= 0 && c.room.checksum_interval <= 65535, "checksum interval must be 0..65535");
    need(c.room.history_s >= 1 && c.room.history_s <= 86400, "history must be 1..86400 s");
    need(c.room.max_frames_ahead >= 8 && c.room.max_frames_ahead <= 480, "max frames ahead must be 8..480");
    need(c.room.max_spectators >= 0 && c.room.max_spectators <= 64, "max spectators must be 0..64");
    need(c.max_rooms >= 1, "room limit must be >= 1");
    need(c.max_connections >= 2, "connection limit must be >= 2");
    need(c.max_bad_packets >= 1, "max bad packets must be >= 1");
    need(c.packets_per_second > 0 && c.packet_burst >= 1, "packet rate and burst must be positive");
}

RelayServer::RelayServer(const ServerConfig& config) : config_(config) { validate(config_); }
RelayServer::~RelayServer() = default;

void RelayServer::emit(ServerEvent e) {
    if (events_.size() >= 4096) events_.pop_front();  // the log fell behind: keep the newest
    events_.push_back(std::move(e));
}

const RelayRoom* RelayServer::room(std::uint64_t id) const {
    auto it = rooms_.find(id);
    return it == rooms_.end() ? nullptr : it->second.room.get();
}

void RelayServer::on_connect(ConnectionId c, std::uint64_t now_us) {
    if (connections_.count(c)) return;
    Connection conn;
    conn.connected_us = now_us;
    conn.tokens = config_.packet_burst;
    conn.refill_us = now_us;
    connections_.emplace(c, conn);
    unbound_.emplace_back(c, now_us);
    if (connections_.size() > config_.max_connections) kick(c, connections_[c], "server connection limit", now_us);
}

void RelayServer::on_disconnect(ConnectionId c, std::uint64_t now_us) {
    auto it = connections_.find(c);
    if (it == connections_.end()) return;
    const Connection conn = it->second;
    connections_.erase(it);
    if (config_.token_key)
        if (auto t = tokens_in_use_.find(tag_key(conn.token_tag)); t != tokens_in_use_.end() && t->second == c)
            tokens_in_use_.erase(t);
    if (!conn.bound) return;
    auto r = rooms_.find(conn.room);
    if (r == rooms_.end()) return;
    const int slot = r->second.room->slot_of(c);
    r->second.room->remove(c, now_us);
    emit({ServerEvent::Kind::Left, conn.room, slot, r->second.room->confirmed_frames(), c, {}});
    close_room_if_done(conn.room);
}

void RelayServer::kick(ConnectionId c, Connection& conn, const char* why, std::uint64_t now_us) {
    (void)now_us;
    if (conn.kicked) return;
    conn.kicked = true;
    ++counters_.kicks;
    kicks_.push_back(c);
    int slot = -1;
    if (conn.bound)
        if (auto r = rooms_.find(conn.room); r != rooms_.end()) slot = r->second.room->slot_of(c);
    emit({ServerEvent::Kind::Kicked, conn.room, slot, 0, c, why});
}

void RelayServer::bad(ConnectionId c, Connection& conn, const char* why, std::uint64_t now_us) {
    ++counters_.bad_packets;
    if (++conn.bad > static_cast<std::uint64_t>(config_.max_bad_packets)) kick(c, conn, why, now_us);
}

void RelayServer::refuse(ConnectionId c, RelayRefusal why, const RelayHello& h) {
    RelayWelcome w;
    w.refusal = why;
    w.echo_us = h.stamp_us;
    encode(w, out_.add(c, true).bytes);
}

void RelayServer::receive(ConnectionId c, std::span<const std::uint8_t> d, std::uint64_t now_us) {
    auto it = connections_.find(c);
    if (it == connections_.end()) return;  // the transport reports connections first
    Connection& conn = it->second;
    ++counters_.datagrams_in;
    counters_.bytes_in += d.size();
    if (conn.kicked) return;
    // Token bucket: a flood is dropped here, before any decoding, and kicked if it goes on.
    conn.tokens = std::min(config_.packet_burst,
                           conn.tokens + static_cast<double>(now_us - conn.refill_us) * config_.packets_per_second / 1e6);
    conn.refill_us = now_us;
    if (conn.tokens < 1) {
        ++counters_.throttled;
        if (++conn.throttled == 1) emit({ServerEvent::Kind::Throttled, conn.room, -1, 0, c, {}});
        if (conn.throttled > config_.flood_kick_after) kick(c, conn, "flooding", now_us);
        return;
    }
    conn.tokens -= 1;
    if (d.size() > kRelayMaxDatagramBytes) return bad(c, conn, "oversized datagram", now_us);
    const auto kind = peek_relay_kind(d);
    if (!conn.bound) {
        if (kind != RelayKind::Hello) return bad(c, conn, "datagram before hello", now_us);
        return handle_hello(c, conn, d, now_us);
    }
    auto r = rooms_.find(conn.room);
    if (r == rooms_.end()) return;
    if (kind == RelayKind::Hello) {
        // A repeat of its own hello is harmless; a hello for another slot (or another set of
        // slots) is a spoof.
        if (const char* e = decode(d, hello_)) return bad(c, conn, e, now_us);
        const int id = r->second.room->slot_of(c);
        if (hello_.room_id == conn.room &&
            (hello_.role == RelayRole::Spectator ? id >= r->second.room->players()
                                                 : id == hello_.slot && relay_hello_slots(hello_) == r->second.room->connection_slots(c)))
            return r->second.room->welcome_again(c, hello_, now_us, out_);
        refuse(c, RelayRefusal::Spoof, hello_);
        return bad(c, conn, "hello for another slot", now_us);
    }
    const std::size_t verdicts = r->second.room->desync_verdicts().size();
    const bool was_started = r->second.room->started();
    const bool was_pending = r->second.room->frames_pending();
    if (const char* e = r->second.room->receive(c, d, now_us, out_)) bad(c, conn, e, now_us);
    if (!was_pending && r->second.room->frames_pending()) pending_rooms_.push_back(conn.room);
    report_verdicts(*r->second.room, conn.room, verdicts, now_us);
    if (!was_started && r->second.room->started()) {
        emit({ServerEvent::Kind::RoomStarted, conn.room, -1, 0, c, {}});
        schedule(conn.room, r->second.room->next_tick_us());
    }
}

void RelayServer::handle_hello(ConnectionId c, Connection& conn, std::span<const std::uint8_t> d, std::uint64_t now_us) {
    if (const char* e = decode(d, hello_)) return bad(c, conn, e, now_us);
    const RelayHello& h = hello_;
    auto refused = [&](RelayRefusal why) {
        ++counters_.hellos_refused;
        refuse(c, why, h);
        emit({ServerEvent::Kind::Refused, h.room_id, h.slot, 0, c, relay_refusal_name(why)});
        kick(c, conn, relay_refusal_name(why), now_us);
    };
    if (h.version != kRelayProtocolVersion) return refused(RelayRefusal::Version);
    if (config_.token_key) {
        if (const RelayRefusal why = check_token(c, h, now_us); why != RelayRefusal::None) {
            ++(why == RelayRefusal::TokenInUse ? counters_.token_replays : counters_.tokens_refused);
            return refused(why);
        }
    }
    // Draining refuses new rooms and rooms that have not started, but not a hello into a running
    // room: that is one of its players (or a restarted process, or a spectator) reconnecting
    // after ENet dropped its connection, and refusing it would end the match drain promises to
    // let finish. The room's own admit() still decides whether the slot is its to take.
    if (draining_) {
        const auto running = rooms_.find(h.room_id);
        if (running == rooms_.end() || !running->second.room->started()) return refused(RelayRefusal::Draining);
    }
    if (h.players < 1 || h.players > kRelayMaxPlayers || h.input_size < 1 || h.input_size > kRelayMaxInputSize ||
        h.tick_rate < 1 || h.tick_rate > 1000)
        return refused(RelayRefusal::RoomParams);
    auto it = rooms_.find(h.room_id);
    const bool created = it == rooms_.end();
    if (created) {
        if (rooms_.size() >= config_.max_rooms) return refused(RelayRefusal::Full);
        it = rooms_.emplace(h.room_id, RoomSlot{std::make_unique<RelayRoom>(h.room_id, h, config_.room), 0}).first;
        schedule(h.room_id, now_us);
        ++counters_.rooms_created;
        emit({ServerEvent::Kind::RoomCreated, h.room_id, -1, 0, c, {}});
    }
    RelayRoom& room = *it->second.room;
    const bool was_started = room.started();
    ConnectionId replaced = 0;
    bool has_replaced = false;
    const std::size_t before = out_.size();
    const RelayRefusal why = room.admit(c, h, now_us, out_, &replaced);
    (void)before;
    if (why != RelayRefusal::None) {
        ++counters_.hellos_refused;
        emit({ServerEvent::Kind::Refused, h.room_id, h.slot, 0, c, relay_refusal_name(why)});
        kick(c, conn, relay_refusal_name(why), now_us);
        if (created) close_room_if_done(h.room_id);
        return;
    }
    has_replaced = replaced != 0 && replaced != c;
    conn.bound = true;
    conn.room = h.room_id;
    if (config_.token_key) {
        conn.client_id = grant_.client_id;
        conn.incarnation = h.incarnation;
        conn.token_tag = tag_;
        tokens_in_use_[tag_key(tag_)] = c;
    }
    emit({ServerEvent::Kind::Joined, h.room_id, room.slot_of(c), room.confirmed_frames(), c,
          h.role == RelayRole::Spectator ? "spectator" : (h.role == RelayRole::Joiner ? "joiner" : "player")});
    if (!was_started && room.started()) {
        emit({ServerEvent::Kind::RoomStarted, h.room_id, -1, 0, c, {}});
        schedule(h.room_id, room.next_tick_us());
    }
    if (has_replaced) {
        auto old = connections_.find(replaced);
        if (old != connections_.end()) {
            old->second.bound = false;  // its slot now belongs to c
            kick(replaced, old->second, "replaced by a restarted process", now_us);
        }
    }
}

RelayRefusal RelayServer::check_token(ConnectionId c, const RelayHello& h, std::uint64_t now_us) {
    if (h.token.empty()) return RelayRefusal::TokenMissing;
    if (open_token(h.token, *config_.token_key, grant_, tag_)) return RelayRefusal::TokenInvalid;
    if (const RelayRefusal why = check_grant(grant_, h, unix_s(now_us)); why != RelayRefusal::None) return why;
    const auto room = rooms_.find(h.room_id);
    if (room == rooms_.end()) return RelayRefusal::None;  // a new room, from this token's parameters
    // A replay: the token is held by a live connection of another process (the same process on
    // a new connection shows its incarnation, and resumes).
    if (const auto u = tokens_in_use_.find(tag_key(tag_)); u != tokens_in_use_.end() && u->second != c) {
        const auto holder = connections_.find(u->second);
        if (holder != connections_.end() && holder->second.bound && !holder->second.kicked &&
            holder->second.token_tag == tag_ && holder->second.incarnation != h.incarnation &&
            room->second.room->live(u->second, now_us))
            return RelayRefusal::TokenInUse;
    }
    // A held slot (its connection live or silent) goes back only to its client id: each slot
    // the hello names.
    const std::uint16_t want = relay_hello_slots(h);
    for (int s = 0; s < room->second.room->players(); ++s) {
        ConnectionId held = 0;
        if ((want & (1u << s)) && room->second.room->holder(s, held) && held != c)
            if (const auto hc = connections_.find(held); hc != connections_.end() && hc->second.client_id != grant_.client_id)
                return RelayRefusal::SlotOwned;
    }
    return RelayRefusal::None;
}

void RelayServer::set_wall_clock(std::uint64_t unix_us, std::uint64_t now_us) {
    wall_offset_us_ = static_cast<std::int64_t>(unix_us) - static_cast<std::int64_t>(now_us);
}

std::uint64_t RelayServer::unix_s(std::uint64_t now_us) const {
    const std::int64_t t = static_cast<std::int64_t>(now_us) + wall_offset_us_;
    return t <= 0 ? 0 : static_cast<std::uint64_t>(t) / 1000000u;
}

void RelayServer::send_pending() {
    for (std::uint64_t id : pending_rooms_)
        if (auto r = rooms_.find(id); r != rooms_.end()) r->second.room->send_pending(out_);
    pending_rooms_.clear();
}

void RelayServer::tick(std::uint64_t now_us) {
    send_pending();
    // Hello timeouts: the oldest unbound connections first; bound, gone or kicked ones leave.
    while (!unbound_.empty()) {
        const auto [c, since] = unbound_.front();
        auto it = connections_.find(c);
        if (it != connections_.end() && it->second.connected_us == since && !it->second.bound && !it->second.kicked) {
            if (now_us - since < config_.hello_timeout_us) break;
            kick(c, it->second, "no hello", now_us);
        }
        unbound_.pop_front();
    }
    const std::uint64_t now_ms = now_us / 1000;
    if (!wheel_started_) {
        wheel_started_ = true;
        wheel_ms_ = now_ms;
    }
    if (now_ms < wheel_ms_) return;  // a clock that went back: nothing new is due
    if (now_ms >= wheel_ms_ + kWheelSlots) wheel_ms_ = now_ms + 1 - kWheelSlots;  // a long gap: each slot once
    for (;;) {
        // The slot's entries: the due ones serviced, the others (later this ms, or a lap ahead) kept.
        std::vector<DueEntry>& slot = wheel_[wheel_ms_ % kWheelSlots];
        if (!slot.empty()) {
            wheel_scratch_.swap(slot);
            for (const DueEntry& e : wheel_scratch_) {
                if (e.due <= now_us) service_room(e.room, e.due, now_us);
                else wheel_[(e.due / 1000 > wheel_ms_ ? e.due / 1000 : wheel_ms_) % kWheelSlots].push_back(e);
            }
            wheel_scratch_.clear();
        }
        if (wheel_ms_ == now_ms) break;
        ++wheel_ms_;
    }
}

void RelayServer::report_verdicts(RelayRoom& room, std::uint64_t id, std::size_t from, std::uint64_t now_us) {
    const auto& v = room.desync_verdicts();
    if (v.size() == from && !room.has_kicks()) return;  // nothing new (every datagram asks)
    for (std::size_t i = from; i < v.size(); ++i) {
        ConnectionId c = 0;
        room.holder(v[i].second, c);
        emit({ServerEvent::Kind::Desync, id, v[i].second, v[i].first, c,
              room.ended_without_majority() ? "two players disagree, no majority: the match ends"
                                            : "checksum in the minority"});
    }
    liars_.clear();
    room.take_kicks(liars_);
    for (ConnectionId c : liars_)
        if (auto it = connections_.find(c); it != connections_.end()) kick(c, it->second, "checksum in the minority round after round", now_us);
}

void RelayServer::schedule(std::uint64_t id, std::uint64_t due_us) {
    auto it = rooms_.find(id);
    if (it == rooms_.end()) return;
    schedule(it->second, id, due_us);
}

void RelayServer::schedule(RoomSlot& r, std::uint64_t id, std::uint64_t due_us) {
    if (r.due != 0 && r.due <= due_us) return;  // already due by then
    r.due = due_us;
    const std::uint64_t ms = due_us / 1000;
    if (!wheel_started_) {
        wheel_started_ = true;
        wheel_ms_ = ms;
    }
    wheel_[(ms < wheel_ms_ ? wheel_ms_ : ms) % kWheelSlots].push_back({due_us, id});
}

void RelayServer::service_room(std::uint64_t id, std::uint64_t due, std::uint64_t now_us) {
    auto r = rooms_.find(id);
    if (r == rooms_.end() || r->second.due != due) return;  // stale entry
    r->second.due = 0;
    RelayRoom& room = *r->second.room;
    const std::size_t verdicts = room.desync_verdicts().size();
    room.tick(now_us, out_);
    report_verdicts(room, id, verdicts, now_us);
    silent_.clear();
    room.silent_connections(now_us, silent_);
    for (ConnectionId c : silent_) {
        room.remove(c, now_us);
        auto it = connections_.find(c);
        if (it != connections_.end()) {
            it->second.bound = false;
            kick(c, it->second, "silent", now_us);
        }
    }
    if ((room.started() || draining_) && room.empty()) {
        close_room_if_done(id);
        return;
    }
    const std::uint64_t period = 1000000u / static_cast<std::uint64_t>(std::max(1, room.tick_rate()));
    schedule(r->second, id, room.started() ? std::max(room.next_tick_us(), now_us + 1) : now_us + period);
}

void RelayServer::close_room_if_done(std::uint64_t id) {
    auto it = rooms_.find(id);
    if (it == rooms_.end() || !it->second.room->empty()) return;
    // An unstarted room with nobody in it goes too: its creator left before the others came.
    emit({ServerEvent::Kind::RoomClosed, id, -1, it->second.room->confirmed_frames(), 0, {}});
    ++counters_.rooms_closed;
    rooms_.erase(it);  // its wheel entry is now stale
}

void RelayServer::start_drain(std::uint64_t now_us) {
    (void)now_us;
    if (draining_) return;
    draining_ = true;
    RelayNotice n;
    n.kind = RelayNoticeKind::Draining;
    for (auto& [id, r] : rooms_) r.room->notify_all(n, out_);
    std::vector<std::uint64_t> empty;
    for (auto& [id, r] : rooms_)
        if (r.room->empty()) empty.push_back(id);
    for (auto id : empty) close_room_if_done(id);
}

void RelayServer::take_outgoing(std::vector<Outgoing>& out) {
    send_pending();
    send_outgoing([&](Outgoing& o) { out.push_back(std::move(o)); });
}

bool RelayServer::next_kick(ConnectionId& out) {
    if (kicks_.empty()) return false;
    out = kicks_.front();
    kicks_.pop_front();
    return true;
}

bool RelayServer::next_event(ServerEvent& out) {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

}  // namespace lockroll::server
