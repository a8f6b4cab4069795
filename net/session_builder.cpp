#include "net/session_builder.h"

#include "net/clock.h"
#include "net/peer_runner.h"
#include "net/relay_runner.h"
#include "net/tick_schedule.h"
#include "rollback/desync_evidence.h"
#include "rollback/relay_messages.h"
#include "rollback/replay.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>

namespace lockroll::net {

namespace {
constexpr std::size_t kMaxQueuedEvents = 1024;
constexpr std::uint64_t kHelloAgainUs = 500'000;  // a held slot's hello again (RelayRunner's reconnect interval)

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("SessionBuilder: " + what); }

// The relay server's answer when the slot's previous process still holds it: its connection
// was heard within the server's replace_silent_us (a crashed process not yet silent long
// enough). The session's Refused event's reason says which refusal (relay_session.cpp).
bool slot_still_held(const rollback::SessionEvent& e) {
    using R = rollback::SessionEvent::Reason;
    return e.reason == R::SlotTaken || e.reason == R::TokenInUse;
}

// Writes `bytes` to `path` whole: a temporary file beside it, then renamed over it. Throws
// std::runtime_error naming the path.
void write_whole_file(const std::filesystem::path& path, std::string_view bytes) {
    const std::filesystem::path tmp = path.string() + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.flush();
        if (!out) throw std::runtime_error(path.string() + ": cannot write");
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        throw std::runtime_error(path.string() + ": cannot replace: " + ec.message());
    }
}
}  // namespace

// ---- NetSession::Engine: what the builder adds around the session ----

// The session's observer: forwards every callback to the game's, records the replay and writes
// the desync evidence (see the contract in session_builder.h). An automatic rejoin is the
// runner's (net/peer_runner.h, rollback/rejoin.h): the session it drives starts again in place.
struct NetSession::Engine final : rollback::SessionObserver {
    Engine(NetSession& o, rollback::Simulation& s) : owner(o), sim(s) {}

    NetSession& owner;
    rollback::Simulation& sim;
    rollback::SessionObserver* user = nullptr;
    rollback::PlayerId me = 0;                // this process's id, in evidence file names
    std::filesystem::path evidence_dir;       // empty: no files
    std::optional<rollback::ReplayRecorder> replay;
    std::filesystem::path replay_path;
    bool replay_written = false;
    std::string output_error;
    // Set by Synchronized: the session has run (a refusal after that is no restart to retry).
    bool ran = false;
    // Through a server: the config to say hello again with (the same incarnation) while the
    // slot or token is still held by this process's previous one, until it runs; the server.
    std::optional<rollback::RelaySessionConfig> relay_config;
    std::string server_host;
    std::uint16_t server_port = 0;
    std::uint64_t retry_for_us = 0;                   // how long after the first such refusal
    std::optional<std::uint64_t> first_refusal_us;    // the first such refusal
    bool relay_retrying = false;                      // this update(): say hello again
    std::optional<std::uint64_t> hello_again_at_us;   // when (a new connection each time)

    void failed_output(const std::string& why) {
        if (output_error.empty()) output_error = why;
    }
    void write_replay() {
        if (!replay || replay_written) return;
        replay_written = true;
        try {
            const std::vector<std::uint8_t> bytes = rollback::encode_replay(replay->replay());
            write_whole_file(replay_path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
        } catch (const std::exception& e) {
            failed_output(std::string("record_replay: ") + e.what());
        }
    }
    // True for the events a relay client's hello-again swallows: the refusal of a hello for a
    // slot its previous process still holds, and the failure after it, while the retries last.
    // (Peer to peer, the automatic rejoin lives in net::PeerRunner: rollback/rejoin.h.)
    bool hold_back(const rollback::SessionEvent& e) {
        using K = rollback::SessionEvent::Kind;
        if (e.kind == K::Synchronized) ran = true;
        // A player that loads a snapshot before it ever ran is a restarted process rejoining
        // through a server: its frames start there, so no replay from frame 1 (a joiner or a
        // spectator records none anyway).
        if (relay_config && !ran && e.kind == K::SnapshotLoaded) replay.reset();
        if (relay_config && !ran && e.kind == K::Refused && slot_still_held(e)) {
            if (!first_refusal_us) first_refusal_us = e.at_us;
            if (e.at_us - *first_refusal_us < retry_for_us) relay_retrying = true;
        }
        return relay_retrying && (e.kind == K::Refused || e.kind == K::Failed);
    }

    void on_frame_simulated(const rollback::FrameSimulated& f) override {
        if (user) user->on_frame_simulated(f);
    }
    void on_rollback_begin(const rollback::RollbackInfo& r) override {
        if (user) user->on_rollback_begin(r);
    }
    void on_rollback_end(const rollback::RollbackInfo& r) override {
        if (user) user->on_rollback_end(r);
    }
    void on_frame_confirmed(const rollback::FrameConfirmed& f) override {
        if (replay && !replay_written) {
            const std::uint32_t have = replay->replay().frames();
            if (f.frame == have + 1) {
                replay->add(f);
            } else if (owner.session_ && owner.session_->config().role == rollback::Role::Joiner) {
                // Only a rejoin makes a player's session a joiner (record_replay() refuses join()):
                // it goes on from a snapshot. A restart that never confirmed a frame writes no
                // replay; a healed partition's minority keeps the frames it had confirmed.
                if (have == 0) {
                    replay.reset();
                } else {
                    failed_output("record_replay: this process rejoined by snapshot (frame " + std::to_string(f.frame) +
                                  " confirmed next); the replay stops at frame " + std::to_string(have));
                    write_replay();
                }
            } else {  // frames are confirmed once each, in order: only a reload can skip
                failed_output("record_replay: frame " + std::to_string(f.frame) + " confirmed after " +
                              std::to_string(have) + "; the replay stops there");
                write_replay();
            }
        }
        if (user) user->on_frame_confirmed(f);
    }
    void on_desync(const rollback::DesyncEvent& d) override {
        if (user) user->on_desync(d);
    }
    void on_desync_report(const rollback::DesyncReport& r) override {
        std::string detail = r.summary;
        if (!evidence_dir.empty()) {
            const std::string text = rollback::desync_evidence_text(r, sim);
            if (!text.empty()) {
                const std::filesystem::path path = evidence_dir / rollback::desync_evidence_file_name(me, r);
                try {
                    write_whole_file(path, text);
                    detail += "; evidence " + path.string();
                } catch (const std::exception& e) {
                    failed_output(std::string("desync_report_dir: ") + e.what());
                }
            }
        }
        // Into the event stream like the session's own (update()'s, next_event(), the observer).
        owner.on_session_event({rollback::SessionEvent::Kind::DesyncReport, r.peer, r.frame,
                                owner.runner_config_->clock.now_us(), std::move(detail)});
        if (user) user->on_desync_report(r);
    }
    void on_peer_error(rollback::PlayerId peer, const std::string& why) override {
        if (user) user->on_peer_error(peer, why);
    }
};

// ---- NetSession ----

NetSession::NetSession() = default;

NetSession::~NetSession() {
    if (engine_) engine_->write_replay();  // a run that never ended still leaves its replay
    // The sessions hold the engine as their observer: they go first, runners before sessions.
    relay_runner_.reset();
    relay_session_.reset();
    runner_.reset();
    session_.reset();
}

const RunnerConfig& NetSession::runner_config() const { return *runner_config_; }

std::string NetSession::output_error() const { return engine_ ? engine_->output_error : std::string(); }

void NetSession::queue_event(rollback::SessionEvent e) {
    if (events_.size() >= kMaxQueuedEvents) events_.pop_front();
    events_.push_back(std::move(e));
}

// Through a server, the slot still held by the previous process: the same config (the same
// incarnation) on a new RelaySession and runner, which connect to the server again (the server
// closed the refused connection) and say hello. The simulation is still in its initial state:
// the session was never welcomed.
void NetSession::restart_relay() {
    engine_->hello_again_at_us.reset();
    relay_runner_.reset();
    relay_session_.reset();
    relay_session_ = std::make_unique<rollback::RelaySession>(*engine_->relay_config, engine_->sim, engine_.get());
    RunnerObserver* as_observer = this;
    relay_runner_ = std::make_unique<RelayRunner>(
        *runner_config_, engine_->server_host, engine_->server_port, *relay_session_, *transport_,
        [this](std::uint32_t frame, std::span<std::uint8_t> out) { (*input_)(frame, out); }, as_observer);
}

UpdateResult NetSession::update(const InputSource& input, RunnerObserver* observer) {
    if (!input) {  // nothing to play with (a caller's bug; never throws)
        UpdateResult r;
        r.outcome = RunOutcome::Failed;
        return r;
    }
    if (engine_->hello_again_at_us) {
        // Waiting to say hello again (one new connection per half second, as the runner's own
        // reconnects); a stop ends the wait, and the new runner reports it.
        if (runner_config_->clock.now_us() < *engine_->hello_again_at_us && !stop_.load(std::memory_order_relaxed))
            return UpdateResult{};
        restart_relay();
    }
    if (stop_.load(std::memory_order_relaxed)) {
        if (relay_runner_) relay_runner_->request_stop();
        else runner_->request_stop();
    }
    observer_ = observer;
    input_ = &input;
    UpdateResult r = relay_runner_ ? relay_runner_->update() : runner_->update();
    if (engine_->relay_retrying) {
        // The server still counts the previous process as live: not an end, a hello again soon.
        engine_->relay_retrying = false;
        engine_->hello_again_at_us = runner_config_->clock.now_us() + kHelloAgainUs;
        r = UpdateResult{};
    }
    input_ = nullptr;
    observer_ = nullptr;
    if (r.outcome) engine_->write_replay();
    return r;
}

void NetSession::wait() const {
    if (relay_runner_) relay_runner_->wait();
    else runner_->wait();
}

RunOutcome NetSession::run(InputSource input, RunnerObserver* observer) {
    return run_until_over([&] { return update(input, observer); }, [this] { wait(); });
}

// Only the flag: the runner may be replaced (a rejoin, a hello again) on the thread that
// updates, so update() hands the stop to whichever runner it has.
void NetSession::request_stop() { stop_.store(true, std::memory_order_relaxed); }

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
    if (engine_->hold_back(e)) return;
    queue_event(e);
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
// The two spectator() forms replace each other: the last one called is the one that counts.
SessionBuilder& SessionBuilder::spectator(std::string host, std::uint16_t port, int index) {
    engine_.spectate_server = false;
    engine_.spectate = Remote{static_cast<rollback::PlayerId>(std::max(index, 0)), std::move(host), port};
    if (index < 0) engine_.spectate->slot = std::numeric_limits<rollback::PlayerId>::max();  // refused at start()
    return *this;
}
SessionBuilder& SessionBuilder::spectator() {
    engine_.spectate.reset();
    engine_.spectate_server = true;
    return *this;
}
SessionBuilder& SessionBuilder::connect_token(std::vector<std::uint8_t> token) {
    engine_.token = std::move(token);
    return *this;
}
SessionBuilder& SessionBuilder::spectators(int n) { engine_.spectators = n; return *this; }
SessionBuilder& SessionBuilder::join() { engine_.join = true; return *this; }
SessionBuilder& SessionBuilder::observer(rollback::SessionObserver* o) { engine_.observer = o; return *this; }
SessionBuilder& SessionBuilder::desync_report_dir(std::string path) { engine_.desync_report_dir = std::move(path); return *this; }
SessionBuilder& SessionBuilder::record_replay(std::string path, std::string scene_text) {
    engine_.replay_path = std::move(path);
    engine_.replay_scene = std::move(scene_text);
    return *this;
}
SessionBuilder& SessionBuilder::interrupt_timeout(std::uint64_t ms) { engine_.interrupt_ms = ms; return *this; }
SessionBuilder& SessionBuilder::disconnect_timeout(std::uint64_t ms) { engine_.disconnect_ms = ms; return *this; }

// The engine settings' own rules, for both kinds of session.
void SessionBuilder::check_engine_settings() const {
    constexpr std::uint64_t kMaxMs = 3'600'000;  // an hour
    if (engine_.interrupt_ms && (*engine_.interrupt_ms < 1 || *engine_.interrupt_ms > kMaxMs))
        bad("interrupt_timeout(" + std::to_string(*engine_.interrupt_ms) + "): must be 1..3600000 ms");
    if (engine_.disconnect_ms && *engine_.disconnect_ms > kMaxMs)
        bad("disconnect_timeout(" + std::to_string(*engine_.disconnect_ms) + "): must be 0..3600000 ms (0: never)");
    if (engine_.spectators < 0) bad("spectators(" + std::to_string(engine_.spectators) + "): must be >= 0");
    if (engine_.join && spectating()) bad("spectator() and join() exclude each other");
    if (!engine_.replay_path.empty() && (engine_.join || spectating()))
        bad(std::string("record_replay() with ") + (engine_.join ? "join()" : "spectator()") +
            ": it starts from a snapshot, so it has no frames from 1 on to record");
}

SessionBuilder& SessionBuilder::configure_relay(std::function<void(rollback::RelaySessionConfig&, RunnerConfig&)> f) {
    configure_relay_ = std::move(f);
    return *this;
}

rollback::RelaySessionConfig SessionBuilder::relay_config() const {
    if (!server_) bad("relay_config() without server()");
    if (server_->first.empty() || server_->second == 0) bad("server(): needs a host and a port");
    if (!remote_.empty()) bad("server() and remote_player() exclude each other: through a server, nobody's address is needed");
    if (engine_.spectate)
        bad("spectator(host, port) and server() exclude each other: through a server, spectator() takes no address "
            "(the server places the spectator)");
    if (engine_.spectators != 0)
        bad("spectators(" + std::to_string(engine_.spectators) +
            ") and server() exclude each other: the relay server sets the spectator places of a room "
            "(lockroll server --max-spectators)");
    if (players_ < 1 || players_ > rollback::kRelayMaxPlayers) bad("players must be 1.." + std::to_string(rollback::kRelayMaxPlayers) + " through a server");
    if (input_size_ == 0) bad("input_size() is required (bytes per player and frame)");
    if (engine_.spectate_server && !local_.empty())
        bad("spectator() and local_player() exclude each other: a spectator plays no slot");
    if (!engine_.spectate_server && local_.empty())
        bad("no local_player(): name the slot(s) this machine plays (or spectator() to watch)");
    if (input_delay_ < 0 || input_delay_ > 60) bad("input_delay must be 0..60");
    if (engine_.token && engine_.token->size() > rollback::kRelayMaxTokenBytes)
        bad("connect_token(): " + std::to_string(engine_.token->size()) + " bytes, at most " +
            std::to_string(rollback::kRelayMaxTokenBytes));
    check_engine_settings();
    rollback::RelaySessionConfig c;
    if (engine_.join) c.role = rollback::RelayRole::Joiner;
    if (engine_.disconnect_ms.value_or(0) != 0) c.server_timeout_us = *engine_.disconnect_ms * 1000;
    c.players = players_;
    if (engine_.token) c.connect_token = *engine_.token;
    if (engine_.spectate_server) {
        c.role = rollback::RelayRole::Spectator;  // no slot: the server places it
        c.local_slot = 0;
    } else {
        // Several local slots: one connection plays them all (the lowest names it to the server).
        c.local_slot = *std::min_element(local_.begin(), local_.end());
        for (rollback::PlayerId s : local_) {
            if (s >= static_cast<rollback::PlayerId>(players_)) bad("local_player(" + std::to_string(s) + "): slot out of range");
            const auto bit = static_cast<std::uint16_t>(1u << s);
            if (s != c.local_slot && (c.also_slots & bit)) bad("slot " + std::to_string(s) + " is named twice");
            if (s != c.local_slot) c.also_slots = static_cast<std::uint16_t>(c.also_slots | bit);
        }
        if (std::count(local_.begin(), local_.end(), c.local_slot) > 1) bad("slot " + std::to_string(c.local_slot) + " is named twice");
    }
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
    if (engine_.spectate_server)
        bad("spectator() without server(): with no address it watches through a relay server (server(host, port)); "
            "peer to peer, spectator(host, port, index) names slot 0's process");
    if (engine_.token)
        bad("connect_token() without server(): a connect token admits to a relay server; peer to peer has none");
    if (players_ < 1 || players_ > rollback::kMaxPlayers) bad("players must be 1.." + std::to_string(rollback::kMaxPlayers));
    if (input_size_ == 0) bad("input_size() is required (bytes per player and frame)");
    check_engine_settings();
    rollback::SessionConfig c;
    c.players = players_;
    c.input_size = input_size_;
    c.tick_rate = tick_rate_;
    c.input_delay = input_delay_;
    c.cpu_clock = thread_cpu_ns;  // the sessions read no clock themselves
    c.prediction_window = prediction_window_;
    c.handshake = true;
    c.match_id = match_id_;
    c.max_spectators = engine_.spectators;
    if (engine_.interrupt_ms) c.interrupt_us = *engine_.interrupt_ms * 1000;
    if (engine_.disconnect_ms) c.disconnect_us = *engine_.disconnect_ms * 1000;
    if (engine_.spectate) {
        // No slot of its own: an id above the players', served by slot 0's process.
        if (!local_.empty()) bad("spectator() and local_player() exclude each other: a spectator plays no slot");
        if (!remote_.empty())
            bad("spectator() and remote_player() exclude each other: a spectator watches through slot 0's process");
        const Remote& h = *engine_.spectate;
        if (h.host.empty() || h.port == 0) bad("spectator(): needs a host and a port");
        if (h.slot >= static_cast<rollback::PlayerId>(engine_.spectators))
            bad("spectator(): the index must be 0..spectators()-1, and spectators(" + std::to_string(engine_.spectators) +
                ") admits " + (engine_.spectators == 0 ? std::string("none") : std::to_string(engine_.spectators)) +
                " (every process passes the same spectators(n))");
        c.role = rollback::Role::Spectator;
        c.local_player = static_cast<rollback::PlayerId>(players_ + static_cast<int>(h.slot));
        return c;
    }
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
    c.local_player = me;
    if (engine_.join) c.role = rollback::Role::Joiner;
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
    if (engine_.spectate) rc.peers.push_back({0, engine_.spectate->host, engine_.spectate->port});
    for (const Remote& r : remote_) {
        bool first = true;
        for (const Remote& o : remote_)
            if (o.host == r.host && o.port == r.port && o.slot < r.slot) first = false;
        if (first) rc.peers.push_back({r.slot, r.host, r.port});
    }
    return rc;
}

// The engine around the session: observer, evidence directory, replay recorder (each checked
// here, before anything is bound).
std::unique_ptr<NetSession::Engine> SessionBuilder::make_engine(NetSession& s, rollback::Simulation& simulation,
                                                                rollback::PlayerId me, int players) const {
    auto e = std::make_unique<NetSession::Engine>(s, simulation);
    e->user = engine_.observer;
    e->me = me;
    if (!engine_.desync_report_dir.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(engine_.desync_report_dir, ec);
        if (ec || !std::filesystem::is_directory(engine_.desync_report_dir))
            bad("desync_report_dir(" + engine_.desync_report_dir + "): not a directory that can be created" +
                (ec ? ": " + ec.message() : std::string()));
        e->evidence_dir = engine_.desync_report_dir;
    }
    if (!engine_.replay_path.empty()) {
        // Tried now, so a path that cannot be written fails start(), not the end of the match.
        const std::filesystem::path path = engine_.replay_path;
        const bool existed = std::filesystem::exists(path);
        if (std::filesystem::is_directory(path)) bad("record_replay(" + engine_.replay_path + "): is a directory");
        if (!std::ofstream(path, std::ios::binary | std::ios::app)) bad("record_replay(" + engine_.replay_path + "): cannot be written");
        if (!existed) std::filesystem::remove(path);
        rollback::Replay header;
        header.players = static_cast<std::uint32_t>(players);
        header.input_size = static_cast<std::uint32_t>(input_size_);
        header.tick_rate = static_cast<std::uint32_t>(tick_rate_);
        std::vector<std::uint8_t> state(simulation.state_size());
        header.initial_checksum = simulation.checksum(simulation.save_to(state));
        header.scene_name = path.filename().string();
        header.scene_text = engine_.replay_scene;
        e->replay.emplace(std::move(header));
        e->replay_path = path;
    }
    return e;
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
        s->runner_config_ = std::make_unique<RunnerConfig>(rc);
        const bool spectator = rs.role == rollback::RelayRole::Spectator;
        // A spectator's evidence files are named by the first spectator id (its place is the server's).
        s->engine_ = make_engine(*s, simulation, spectator ? static_cast<rollback::PlayerId>(rs.players) : rs.local_slot, rs.players);
        // A restarted process may find its slot (or, a spectator, its token) still held by its
        // previous process: it then says hello again with this config (see the contract).
        s->engine_->relay_config = rs;
        s->engine_->retry_for_us = rc.connect_timeout_us;
        s->engine_->server_host = server_->first;
        s->engine_->server_port = server_->second;
        // Long timeouts on the one connection to the server (30 s of silence; as `lockroll client`).
        attach_transport(*s, rs.local_slot,
                         transport::EnetConfig{.local_id = static_cast<transport::PeerId>(rs.local_slot),
                                               .bind_host = listen_host_,
                                               .port = listen_port_,
                                               .dead_after_us = 30'000'000,
                                               .timeout_limit = 32,
                                               .timeout_min_ms = 5000,
                                               .timeout_max_ms = 30000});
        s->relay_session_ = std::make_unique<rollback::RelaySession>(rs, simulation, s->engine_.get());
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
    s->runner_config_ = std::make_unique<RunnerConfig>(rc);
    s->engine_ = make_engine(*s, simulation, sc.local_player, sc.players);
    attach_transport(*s, sc.local_player,
                     transport::EnetConfig{.local_id = static_cast<transport::PeerId>(sc.local_player),
                                           .bind_host = listen_host_,
                                           .port = listen_port_});
    s->session_ = std::make_unique<rollback::Session>(sc, simulation, s->engine_.get());
    // The runner checks its own config (tick rate, peers) here, not on the first run().
    NetSession* raw = s.get();
    RunnerObserver* as_observer = raw;  // a private base: converted here, where it is accessible
    s->runner_ = std::make_unique<PeerRunner>(
        rc, *s->session_, *s->transport_,
        [raw](std::uint32_t frame, std::span<std::uint8_t> out) { (*raw->input_)(frame, out); }, as_observer);
    return s;
}

}  // namespace lockroll::net
