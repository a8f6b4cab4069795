#include "net/session_builder.h"

#include "net/clock.h"
#include "net/tick_schedule.h"

#include <algorithm>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>

namespace lockroll::net {

namespace {
constexpr std::size_t kMaxQueuedEvents = 1024;

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("SessionBuilder: " + what); }
}  // namespace

// ---- NetSession ----

NetSession::~NetSession() = default;

UpdateResult NetSession::update(const InputSource& input, RunnerObserver* observer) {
    if (!input) {  // nothing to play with (a caller's bug; never throws)
        UpdateResult r;
        r.outcome = RunOutcome::Failed;
        return r;
    }
    observer_ = observer;
    input_ = &input;
    UpdateResult r = relay_runner_ ? relay_runner_->update() : runner_->update();
    input_ = nullptr;
    observer_ = nullptr;
    return r;
}

void NetSession::wait() const {
    if (relay_runner_) relay_runner_->wait();
    else runner_->wait();
}

RunOutcome NetSession::run(InputSource input, RunnerObserver* observer) {
    return run_until_over([&] { return update(input, observer); }, [this] { wait(); });
}

void NetSession::request_stop() {
    if (relay_runner_) relay_runner_->request_stop();
    else runner_->request_stop();
}

std::span<const rollback::PlayerId> NetSession::local_slots() const {
    if (relay_session_) return relay_slots_;
    return session_->local_slots();
}

std::optional<std::uint64_t> NetSession::confirmed_checksum(std::uint32_t frame) const {
    return relay_session_ ? relay_session_->confirmed_checksum(frame) : session_->confirmed_checksum(frame);
}

bool NetSession::next_event(rollback::SessionEvent& out) {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

rollback::NetworkStats NetSession::network_stats(rollback::PlayerId peer) const {
    if (relay_session_) {
        rollback::NetworkStats n;
        n.ping_us = relay_session_->rtt_us();
        n.jitter_us = relay_session_->jitter_us();
        n.frames_behind = relay_session_->behind(net::now_us());
        n.send_queue = relay_session_->frame() + static_cast<std::uint32_t>(relay_session_->input_delay()) -
                       std::min(relay_session_->frame() + static_cast<std::uint32_t>(relay_session_->input_delay()),
                                relay_session_->server_input_ack());
        return n;
    }
    return session_->network_stats(peer, net::now_us());
}

void NetSession::on_transport_event(const transport::TransportEvent& e, std::uint64_t now_us) {
    if (observer_) observer_->on_transport_event(e, now_us);
}
void NetSession::on_session_event(const rollback::SessionEvent& e) {
    if (events_.size() >= kMaxQueuedEvents) events_.pop_front();
    events_.push_back(e);
    if (observer_) observer_->on_session_event(e);
}
void NetSession::on_synchronized(std::uint64_t now_us) {
    if (observer_) observer_->on_synchronized(now_us);
}
void NetSession::on_tick(const TickReport& r) {
    if (observer_) observer_->on_tick(r);
}
void NetSession::on_all_confirmed(std::uint64_t now_us) {
    if (observer_) observer_->on_all_confirmed(now_us);
}

// ---- SessionBuilder ----

SessionBuilder& SessionBuilder::players(int n) { players_ = n; return *this; }
SessionBuilder& SessionBuilder::input_size(std::size_t bytes) { input_size_ = bytes; return *this; }
SessionBuilder& SessionBuilder::local_player(rollback::PlayerId slot) { local_.push_back(slot); return *this; }
SessionBuilder& SessionBuilder::remote_player(rollback::PlayerId slot, std::string host, std::uint16_t port) {
    remote_.push_back({slot, std::move(host), port});
    return *this;
}
SessionBuilder& SessionBuilder::server(std::string host, std::uint16_t port) {
    server_.emplace(std::move(host), port);
    return *this;
}
SessionBuilder& SessionBuilder::listen(std::string host, std::uint16_t port) {
    listen_host_ = std::move(host);
    listen_port_ = port;
    listen_set_ = true;
    return *this;
}
SessionBuilder& SessionBuilder::transport(transport::Transport& t) {
    transport_ = &t;
    owned_transport_.reset();
    return *this;
}
SessionBuilder& SessionBuilder::transport(std::unique_ptr<transport::Transport> t) {
    transport_ = nullptr;
    owned_transport_ = std::move(t);
    return *this;
}

void SessionBuilder::attach_transport(NetSession& s, rollback::PlayerId id, const transport::EnetConfig& enet) const {
    if (transport_ || owned_transport_) {
        if (listen_set_) bad("listen() and transport() exclude each other: your transport is bound already");
        // Owned by one NetSession: a second start() from this builder would share it.
        if (owned_transport_ && owned_transport_.use_count() > 1) bad("transport(unique_ptr): already in use by a started session");
        transport::Transport& t = transport_ ? *transport_ : *owned_transport_;
        if (t.local_id() != id)
            bad("transport(): its local_id() is " + std::to_string(t.local_id()) + ", this process's slot is " + std::to_string(id));
        s.owned_ = owned_transport_;
        s.transport_ = &t;
        return;
    }
    auto e = std::make_shared<transport::EnetTransport>(enet);
    s.enet_ = e.get();
    s.transport_ = e.get();
    s.owned_ = std::move(e);
}
SessionBuilder& SessionBuilder::tick_rate(int hz) { tick_rate_ = hz; return *this; }
SessionBuilder& SessionBuilder::input_delay(int frames) {
    input_delay_ = frames;
    input_delay_set_ = true;
    return *this;
}
SessionBuilder& SessionBuilder::prediction_window(int frames) {
    prediction_window_ = frames;
    prediction_window_set_ = true;
    return *this;
}
SessionBuilder& SessionBuilder::configure_relay(std::function<void(rollback::RelaySessionConfig&, RunnerConfig&)> f) {
    configure_relay_ = std::move(f);
    return *this;
}

rollback::RelaySessionConfig SessionBuilder::relay_config() const {
    if (!server_) bad("relay_config() without server()");
    if (server_->first.empty() || server_->second == 0) bad("server(): needs a host and a port");
    if (!remote_.empty()) bad("server() and remote_player() exclude each other: through a server, nobody's address is needed");
    if (players_ < 1 || players_ > rollback::kRelayMaxPlayers) bad("players must be 1.." + std::to_string(rollback::kRelayMaxPlayers) + " through a server");
    if (input_size_ == 0) bad("input_size() is required (bytes per player and frame)");
    if (local_.empty()) bad("no local_player(): name the slot(s) this machine plays");
    if (input_delay_ < 0 || input_delay_ > 60) bad("input_delay must be 0..60");
    rollback::RelaySessionConfig c;
    c.players = players_;
    // Several local slots: one connection plays them all (the lowest names it to the server).
    c.local_slot = *std::min_element(local_.begin(), local_.end());
    for (rollback::PlayerId s : local_) {
        if (s >= static_cast<rollback::PlayerId>(players_)) bad("local_player(" + std::to_string(s) + "): slot out of range");
        const auto bit = static_cast<std::uint16_t>(1u << s);
        if (s != c.local_slot && (c.also_slots & bit)) bad("slot " + std::to_string(s) + " is named twice");
        if (s != c.local_slot) c.also_slots = static_cast<std::uint16_t>(c.also_slots | bit);
    }
    if (std::count(local_.begin(), local_.end(), c.local_slot) > 1) bad("slot " + std::to_string(c.local_slot) + " is named twice");
    c.input_size = input_size_;
    c.tick_rate = tick_rate_;
    c.input_delay = input_delay_;
    c.cpu_clock = thread_cpu_ns;  // the sessions read no clock themselves
    c.auto_input_delay = !input_delay_set_;
    c.prediction_window = prediction_window_set_ ? prediction_window_ : 20;
    c.room_id = match_id_;
    return c;
}
SessionBuilder& SessionBuilder::match_id(std::uint64_t id) { match_id_ = id; return *this; }
SessionBuilder& SessionBuilder::frames(std::uint32_t n) { frames_ = n; return *this; }
SessionBuilder& SessionBuilder::configure(std::function<void(rollback::SessionConfig&, RunnerConfig&)> f) {
    configure_ = std::move(f);
    return *this;
}

rollback::SessionConfig SessionBuilder::session_config() const {
    if (server_) bad("session_config() with server(): through a server the session is a RelaySession (relay_config())");
    if (players_ < 1 || players_ > rollback::kMaxPlayers) bad("players must be 1.." + std::to_string(rollback::kMaxPlayers));
    if (input_size_ == 0) bad("input_size() is required (bytes per player and frame)");
    if (local_.empty()) bad("no local_player(): name the slot(s) this machine plays");
    const auto n = static_cast<std::size_t>(players_);
    // Every slot named exactly once; the host of a group is its lowest slot.
    std::vector<int> host(n, -1);
    const auto name = [&](rollback::PlayerId s, const char* how) {
        if (s >= n) bad(std::string(how) + "(" + std::to_string(s) + "): slot out of range 0.." + std::to_string(n - 1));
        if (host[s] != -1) bad("slot " + std::to_string(s) + " is named twice");
    };
    const rollback::PlayerId me = *std::min_element(local_.begin(), local_.end());
    for (rollback::PlayerId s : local_) {
        name(s, "local_player");
        host[s] = me;
    }
    std::map<std::pair<std::string, std::uint16_t>, rollback::PlayerId> process;  // address -> lowest slot
    for (const Remote& r : remote_) {
        if (r.host.empty() || r.port == 0) bad("remote_player(" + std::to_string(r.slot) + "): needs a host and a port");
        auto [it, fresh] = process.try_emplace({r.host, r.port}, r.slot);
        if (!fresh) it->second = std::min(it->second, r.slot);
    }
    for (const Remote& r : remote_) {
        name(r.slot, "remote_player");
        host[r.slot] = process.at({r.host, r.port});
    }
    for (std::size_t s = 0; s < n; ++s)
        if (host[s] == -1) bad("slot " + std::to_string(s) + " is neither local_player() nor remote_player()");
    rollback::SessionConfig c;
    c.players = players_;
    c.local_player = me;
    c.input_size = input_size_;
    c.tick_rate = tick_rate_;
    c.input_delay = input_delay_;
    c.cpu_clock = thread_cpu_ns;  // the sessions read no clock themselves
    c.prediction_window = prediction_window_;
    c.handshake = true;
    c.match_id = match_id_;
    bool shared = false;
    for (std::size_t s = 0; s < n; ++s) shared = shared || static_cast<std::size_t>(host[s]) != s;
    if (shared)  // several slots in one process; otherwise every slot is its own peer
        for (std::size_t s = 0; s < n; ++s) c.slot_hosts.push_back(static_cast<rollback::PlayerId>(host[s]));
    return c;
}

RunnerConfig SessionBuilder::runner_config() const {
    RunnerConfig rc;
    rc.tick_rate = tick_rate_;
    // 0 frames: no end but request_stop() (frame numbers never get near 2^32 in a session).
    rc.target_frame = frames_ != 0 ? frames_ : std::numeric_limits<std::uint32_t>::max();
    for (const Remote& r : remote_) {
        bool first = true;
        for (const Remote& o : remote_)
            if (o.host == r.host && o.port == r.port && o.slot < r.slot) first = false;
        if (first) rc.peers.push_back({r.slot, r.host, r.port});
    }
    return rc;
}

std::unique_ptr<NetSession> SessionBuilder::start(rollback::Simulation& simulation) const {
    if (server_) {
        rollback::RelaySessionConfig rs = relay_config();
        RunnerConfig rc = runner_config();
        if (configure_relay_) configure_relay_(rs, rc);
        // The token the server resumes this process's slot with after a reconnect: random.
        std::random_device rd;
        if (rs.incarnation == 0) rs.incarnation = (static_cast<std::uint64_t>(rd()) << 32 | rd()) | 1;
        rollback::validate(rs);
        std::unique_ptr<NetSession> s(new NetSession());
        s->runner_config_ = rc;
        // ENet's own long timeouts on the one connection to the server (as `lockroll client`).
        attach_transport(*s, rs.local_slot,
                         transport::EnetConfig{.local_id = static_cast<transport::PeerId>(rs.local_slot),
                                               .bind_host = listen_host_,
                                               .port = listen_port_,
                                               .timeout_limit = 32,
                                               .timeout_min_ms = 5000,
                                               .timeout_max_ms = 30000});
        s->relay_session_ = std::make_unique<rollback::RelaySession>(rs, simulation);
        s->relay_slots_ = s->relay_session_->local_slots();  // the input's order: ascending slots
        NetSession* raw = s.get();
        RunnerObserver* as_observer = raw;
        s->relay_runner_ = std::make_unique<RelayRunner>(
            rc, server_->first, server_->second, *s->relay_session_, *s->transport_,
            [raw](std::uint32_t frame, std::span<std::uint8_t> out) { (*raw->input_)(frame, out); }, as_observer);
        return s;
    }
    rollback::SessionConfig sc = session_config();
    RunnerConfig rc = runner_config();
    if (configure_) configure_(sc, rc);
    rollback::validate(sc);  // names the field, before anything is bound
    std::unique_ptr<NetSession> s(new NetSession());
    s->runner_config_ = rc;
    attach_transport(*s, sc.local_player,
                     transport::EnetConfig{.local_id = static_cast<transport::PeerId>(sc.local_player),
                                           .bind_host = listen_host_,
                                           .port = listen_port_});
    s->session_ = std::make_unique<rollback::Session>(sc, simulation);
    // The runner checks its own config (tick rate, peers) here, not on the first run().
    NetSession* raw = s.get();
    RunnerObserver* as_observer = raw;  // a private base: converted here, where it is accessible
    s->runner_ = std::make_unique<PeerRunner>(
        rc, *s->session_, *s->transport_,
        [raw](std::uint32_t frame, std::span<std::uint8_t> out) { (*raw->input_)(frame, out); }, as_observer);
    return s;
}

}  // namespace lockroll::net
