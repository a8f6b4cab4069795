// SessionBuilder: the high-level entry point for the common case, in the spirit of GGRS's
// SessionBuilder. A game states its slots (which are local, where the others listen), its
// Simulation and its input size, and gets back a NetSession: a rollback::Session on ENet (or the
// game's own transport::Transport) at the tick rate (net::PeerRunner) with its events, driven by
// the game's loop (update()) or by its own (run()). The sans-IO rollback::Session stays available
// underneath (NetSession::session()) and on its own for engines with their own sockets.
//
// Contract
//  - Configuration errors throw at start(): std::invalid_argument naming the setting (a slot
//    named twice or never, no local slot, a bad delay, ...), std::runtime_error when the UDP port
//    cannot be bound, std::logic_error for server() (see below). Nothing NetSession does per
//    tick throws: failures come back as RunOutcome values and events.
//  - Slots: every slot 0..players-1 is named exactly once, by local_player() or remote_player()
//    (a spectator names none: spectator() below).
//    Several local slots are several players on this machine (couch + online); remote slots
//    that share an address are one remote process. Each process is known by its lowest slot
//    (its ENet peer id); the others' streams are authored by it (SessionConfig::slot_hosts).
//    Every process must be built with the same slots, players, input size, tick rate, input
//    delay, prediction window and match id.
//  - Addresses: every process listens on listen() (default 127.0.0.1, an ephemeral port:
//    NetSession::port()); remote_player() gives where the others listen. Connections follow
//    PeerRunner's rules (the lower process connects, retried
//    at a backing-off interval of 0.5 s to 4 s: net/redial_backoff.h).
//  - server(host, port): play through a relay server (`lockroll server`, docs/relay.md) instead
//    of a mesh: no remote_player(), one or more local_player() (several are several slots on
//    one connection; the input is then input_size bytes per local slot, ascending slot order,
//    which is local_slots()) or spectator() (below), match_id() is the room.
//    NetSession then runs a rollback::RelaySession with net::RelayRunner; session() is the
//    mesh's only (relay_session() here). Without input_delay() the delay adapts to the round
//    trip; without prediction_window() the window is 20 frames (a 300 ms round trip).
//  - Defaults are those of a real network: handshake on (match id, hello/RTT phase before frame
//    0, agreed drops), input delay 2, prediction window 8 (0 = lockstep), 60 Hz, run until
//    request_stop() (frames(N): until N frames are confirmed everywhere). configure() reaches
//    every SessionConfig field the builder does not name (and, in-tree code that includes
//    net/peer_runner.h, every RunnerConfig field: pacing, timeouts, the clock).
//  - transport(t): the game's own transport::Transport instead of ENet (any that keeps
//    transport/transport.h's contract: Steam networking sockets, WebRTC, plain UDP). Its
//    local_id() must be this process's lowest local slot (through a server: the local slot),
//    else start() throws naming both; listen() then does not apply (start() throws if both are
//    given: your transport is bound already). remote_player()'s and server()'s host and port
//    reach it through Transport::connect(). The reference form must outlive the NetSession; the
//    unique_ptr form is owned by the NetSession (a builder holding one starts one session).
//  - spectator(host, port): watch a peer-to-peer match without playing: no local_player() or
//    remote_player() (start() throws naming them); the player of slot 0 listens at host:port and
//    serves the snapshot and every stream. The spectator's id is players + index, so it needs
//    spectators(n) with n > index, and every player of the match passes the same spectators(n).
//    A spectator of a match with several local players per process is not supported yet.
//  - server(host, port) + spectator() (no address): watch a match played through the relay
//    server: no local_player() (start() throws naming it), players() and input_size() as the
//    room's players pass them, match_id() the room. The server places the spectator (its
//    --max-spectators places per room; spectators(n) does not apply through a server and is
//    refused there, as is spectator(host, port), which names a player's address). Joining a
//    room that has started, it loads a snapshot of the lowest connected player through the
//    server, then follows the confirmed frames; joining before the start, it follows from frame
//    0. With frames(N), run() completes once frame N is confirmed here (a spectator waits for
//    nobody). local_slots() is empty; the input callback is still called once per tick with
//    input_size bytes, which go nowhere. The transport's local_id() is 0 (transport()).
//  - connect_token(bytes): the connect token a backend issued for this process (server/
//    connect_token.h, `lockroll token`), carried opaquely in every hello to a server started
//    with a key: a player's token grants its slot(s), a spectator's token a spectator place
//    (`lockroll token --spectate`). Through a server only (start() throws naming it otherwise);
//    at most 256 bytes. A refused token fails the session with the server's reason (a Refused
//    event, then Failed).
//  - join(): enter a running match by snapshot in this process's slot (a late join into a slot
//    the others start absent: configure()'s absent_slots on every process). Automatic rejoin
//    (peer to peer; net::PeerRunner with RunnerConfig::rejoin_when_dropped, on by default): a
//    session whose slot the others dropped starts again in place as a joiner of that slot
//    (rollback::Session::restart_as_joiner, the join path of `lockroll peer --join`) and
//    rejoins by snapshot. That covers a player process restarted with its usual settings (no
//    join()): it says hello as a player, the running peers recognise a new process for a known
//    slot, drop the old one and refuse it as dropped; and the minority of a partition the
//    majority dropped meanwhile, once the network heals. The failure the drop causes is not
//    passed on; neither is the refusal (kicked) of a session that never ran: a restarted
//    process's game sees snapshot_loaded and synchronized. A healed minority's game sees kicked,
//    then snapshot_loaded and synchronized. session() stays the same object throughout. Through
//    a server join() sets RelayRole::Joiner, and a restarted player (with or without join(), as
//    it was started) needs nothing either: the server binds the slot of a process that left (or
//    went silent) to the new one and names a player to load the snapshot from (events:
//    synchronizing, snapshot_loaded, synchronized). While the old process's connection is still
//    live to the server (heard within its replace_silent_us, 1 s: a crashed process is not yet
//    silent long enough), the hello is refused ("slot held by a live connection", or with
//    connect tokens, spectators' too, "already in use by a live connection"); a NetSession that
//    has not been welcomed yet holds that refusal back and says hello again on a new connection
//    every 0.5 s, for up to RunnerConfig::connect_timeout_us (30 s) from the first refusal, after
//    which the refusal and the failure reach the game. The retry builds a new
//    rollback::RelaySession (take relay_session() again after update()).
//  - observer(o): the game's rollback::SessionObserver sees every frame, rollback, confirmation
//    and desync callback of the session (either kind), as the CLI's recorder does.
//  - desync_report_dir(path): created at start() (throws naming it if it cannot be); once
//    narrowing ends, the evidence file (rollback/desync_evidence.h: the one format `lockroll
//    live` writes) goes there and a DesyncReport event names the peer, the first differing
//    frame, the body and field and the file. Without it the event comes all the same.
//  - record_replay(path, scene_text): the replay (docs/replay-format.md) of every confirmed
//    frame from 1 on, written when the run ends (update()'s outcome) and, if it never ended, when
//    the NetSession is destroyed. scene_text is what the simulation is rebuilt from (for the
//    World: the scene JSON, which `lockroll replay` reads). The path is tried at start()
//    (opened for writing, no file left behind: throws naming it if it cannot be). A joiner or
//    spectator starts from a snapshot: record_replay() with join() or spectator() throws (either
//    kind); a restarted process that rejoined writes none, and one that rejoined after confirming
//    frames (a healed partition's minority) writes those, the rest being a snapshot's
//    (output_error() says where it stops).
//  - interrupt_timeout(ms) / disconnect_timeout(ms): a peer's silence before it is reported
//    interrupted (750 ms) and before this process votes it gone (5000 ms; 0: never);
//    SessionConfig's interrupt_us / disconnect_us. Through a server disconnect_timeout is the
//    server's silence that fails the session (RelaySessionConfig::server_timeout_us, 0: keep);
//    interrupt_timeout does not apply there.
//  - Writing the evidence or the replay never throws from update(): the first failure is kept
//    (NetSession::output_error()).
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/net/update_result.h>
#include <lockroll/rollback/relay_session.h>
#include <lockroll/rollback/session.h>
#include <lockroll/rollback/simulation.h>
#include <lockroll/transport/enet_transport.h>

namespace lockroll::net {

// Held by pointer (or named only as a parameter), so this installed header includes neither
// the runners nor the clock: net/peer_runner.h, net/relay_runner.h, net/clock.h are in-tree.
class PeerRunner;
class RelayRunner;
struct RunnerConfig;  // net/runner_base.h (net/peer_runner.h includes it): configure()'s second argument, complete in-tree only

// A running session over ENet (built by SessionBuilder::start). Not copyable or movable.
class NetSession final : private RunnerObserver {
public:
    NetSession(const NetSession&) = delete;
    NetSession& operator=(const NetSession&) = delete;
    ~NetSession() override;

    // One frame of the game's own loop (GGRS's advance_frame, GGPO's ggpo_idle): never blocks.
    // Reads the runner's clock, receives, runs as many ticks as are due (none when the game's
    // frames are shorter than a tick, several when longer), sends, and returns what happened:
    // frames run, the deepest rollback, the interpolation fraction for drawing between ticks,
    // this call's events, and once the run is over its outcome (see RunOutcome and run()).
    // `input` is called once per tick run, as in run(). Call it at any rate, but often: arrivals
    // are stamped, and pings answered, only while it runs (every frame of a 30 Hz loop adds up to
    // 33 ms to the measured round trip). An empty `input` is a caller's bug: outcome Failed,
    // nothing done. lockroll throws nothing from here; your callbacks' exceptions pass through.
    UpdateResult update(const InputSource& input, RunnerObserver* observer = nullptr);
    // Sleeps until the next tick is due, at most RunnerConfig::service_interval_us: for a loop
    // with nothing else to do between updates.
    void wait() const;
    // update() and wait() until the run is over: plays until the configured frames are
    // confirmed everywhere (Completed), request_stop() (Stopped), the session fails, or a
    // timeout; see RunOutcome. Blocks; `input` is called once per tick for input_size bytes per
    // local slot (local_slots() order). `observer` (optional) sees every tick, session and
    // transport event as they happen. lockroll throws nothing from here; an exception thrown by
    // your own callbacks passes through unchanged.
    RunOutcome run(InputSource input, RunnerObserver* observer = nullptr);
    // Thread- and signal-safe; also fine from inside the callbacks and before run().
    void request_stop();

    // Lifecycle events of the session (SessionEvent), in order, also while run() is going (from
    // its callbacks); the same events update() returns. The newest 1024 are kept.
    bool next_event(rollback::SessionEvent& out);

    // The UDP port ENet bound; 0 with your own transport (transport()).
    std::uint16_t port() const { return enet_ ? enet_->port() : 0; }
    std::span<const rollback::PlayerId> local_slots() const;
    // Overlay figures for a remote process (its lowest slot); through a server: the server's
    // link, whatever `peer` says.
    rollback::NetworkStats network_stats(rollback::PlayerId peer) const;
    // Confirmed checksum of a recent frame (either kind of session).
    std::optional<std::uint64_t> confirmed_checksum(std::uint32_t frame) const;
    bool through_server() const { return relay_session_ != nullptr; }
    // The sans-IO core and the transport underneath, for stats and anything the builder hides.
    // session(): peer to peer only; relay_session(): through a server only.
    rollback::Session& session() { return *session_; }
    const rollback::Session& session() const { return *session_; }
    rollback::RelaySession& relay_session() { return *relay_session_; }
    const rollback::RelaySession& relay_session() const { return *relay_session_; }
    transport::Transport& transport() { return *transport_; }
    // In-tree only (net/peer_runner.h): the runner's config as started.
    const RunnerConfig& runner_config() const;
    // The first failure writing a desync evidence file or the replay (path and why); empty: none.
    std::string output_error() const;

private:
    struct Engine;  // observer, evidence, replay (session_builder.cpp)
    friend class SessionBuilder;
    NetSession();
    void queue_event(rollback::SessionEvent e);
    void restart_relay();  // says hello again on a new RelaySession (a slot still held)
    void on_transport_event(const transport::TransportEvent& e, std::uint64_t now_us) override;
    void on_session_event(const rollback::SessionEvent& e) override;
    void on_synchronized(std::uint64_t now_us) override;
    void on_tick(const TickReport& r) override;
    void on_all_confirmed(std::uint64_t now_us) override;

    std::unique_ptr<RunnerConfig> runner_config_;
    std::shared_ptr<transport::Transport> owned_;  // ENet, or a transport handed over by unique_ptr
    transport::Transport* transport_ = nullptr;     // the one in use
    transport::EnetTransport* enet_ = nullptr;      // when it is the builder's ENet
    std::unique_ptr<rollback::Session> session_;
    std::unique_ptr<PeerRunner> runner_;
    std::unique_ptr<rollback::RelaySession> relay_session_;
    std::unique_ptr<RelayRunner> relay_runner_;
    std::vector<rollback::PlayerId> relay_slots_;
    std::atomic<bool> stop_{false};  // request_stop(), kept for a runner built after it
    RunnerObserver* observer_ = nullptr;
    const InputSource* input_ = nullptr;  // the current update()'s
    std::deque<rollback::SessionEvent> events_;
    std::unique_ptr<Engine> engine_;
};

class SessionBuilder {
public:
    SessionBuilder& players(int n);
    SessionBuilder& input_size(std::size_t bytes);
    // A slot played on this machine; call once per local player.
    SessionBuilder& local_player(rollback::PlayerId slot);
    // A slot played by the process listening at host:port (loopback or not: the builder does
    // not judge addresses; lockroll's own tools keep to loopback).
    SessionBuilder& remote_player(rollback::PlayerId slot, std::string host, std::uint16_t port);
    // Reach the others through a relay server instead (see the contract).
    SessionBuilder& server(std::string host, std::uint16_t port);
    SessionBuilder& listen(std::string host, std::uint16_t port);
    // The game's own transport instead of ENet (see the contract).
    SessionBuilder& transport(transport::Transport& t);
    SessionBuilder& transport(std::unique_ptr<transport::Transport> t);
    SessionBuilder& tick_rate(int hz);
    SessionBuilder& input_delay(int frames);
    SessionBuilder& prediction_window(int frames);  // 0: lockstep
    SessionBuilder& match_id(std::uint64_t id);
    // run() completes once frame n is confirmed by everyone; 0 (default): runs until stopped.
    SessionBuilder& frames(std::uint32_t n);
    // Watch a match without playing, served by the player of slot 0 at host:port; spectator id
    // players + index (see the contract).
    SessionBuilder& spectator(std::string host, std::uint16_t port, int index = 0);
    // Watch a match played through server() without playing: the server places this process
    // (see the contract).
    SessionBuilder& spectator();
    // Spectator ids the match admits (players .. players + n - 1); the same on every process.
    // Peer to peer only: a relay server sets its own limit.
    SessionBuilder& spectators(int n);
    // The connect token for a server started with a key, a player's or a spectator's (see the
    // contract).
    SessionBuilder& connect_token(std::vector<std::uint8_t> token);
    // Enter a running match by snapshot (see the contract; a restart rejoins without it).
    SessionBuilder& join();
    // The game's own session callbacks (must outlive the NetSession).
    SessionBuilder& observer(rollback::SessionObserver* o);
    // Where desync evidence files go (see the contract).
    SessionBuilder& desync_report_dir(std::string path);
    // Record the confirmed inputs to a replay file (see the contract).
    SessionBuilder& record_replay(std::string path, std::string scene_text = {});
    SessionBuilder& interrupt_timeout(std::uint64_t ms);
    SessionBuilder& disconnect_timeout(std::uint64_t ms);  // 0: never drop for silence
    // Last word on every field (called after the builder has filled both configs).
    SessionBuilder& configure(std::function<void(rollback::SessionConfig&, RunnerConfig&)> f);
    // The same, through a server.
    SessionBuilder& configure_relay(std::function<void(rollback::RelaySessionConfig&, RunnerConfig&)> f);

    // Binds the port and builds the session on `simulation` (in its initial state; it must
    // outlive the NetSession). Throws on any configuration error (see the contract).
    std::unique_ptr<NetSession> start(rollback::Simulation& simulation) const;

    // The configs start() would use (validated the same way); for tests and tools.
    rollback::SessionConfig session_config() const;   // peer to peer
    rollback::RelaySessionConfig relay_config() const;  // through server()
    RunnerConfig runner_config() const;                 // in-tree only (net/runner_base.h)

private:
    void check_engine_settings() const;
    bool spectating() const { return engine_.spectate || engine_.spectate_server; }
    std::unique_ptr<NetSession::Engine> make_engine(NetSession& s, rollback::Simulation& simulation, rollback::PlayerId me,
                                                    int players) const;
    // Gives `s` its transport: the game's (its local_id() must be `id`), else ENet as `enet` says.
    void attach_transport(NetSession& s, rollback::PlayerId id, const transport::EnetConfig& enet) const;

    struct Remote {
        rollback::PlayerId slot;
        std::string host;
        std::uint16_t port;
    };
    int players_ = 2;
    std::size_t input_size_ = 0;
    std::vector<rollback::PlayerId> local_;
    std::vector<Remote> remote_;
    std::optional<std::pair<std::string, std::uint16_t>> server_;
    std::string listen_host_ = "127.0.0.1";
    std::uint16_t listen_port_ = 0;
    bool listen_set_ = false;
    transport::Transport* transport_ = nullptr;            // transport(t&)
    std::shared_ptr<transport::Transport> owned_transport_;  // transport(unique_ptr)
    int tick_rate_ = 60;
    int input_delay_ = 2;
    bool input_delay_set_ = false;
    int prediction_window_ = 8;
    bool prediction_window_set_ = false;
    std::uint64_t match_id_ = 0;
    std::uint32_t frames_ = 0;
    std::function<void(rollback::SessionConfig&, RunnerConfig&)> configure_;
    std::function<void(rollback::RelaySessionConfig&, RunnerConfig&)> configure_relay_;
    // The engine's settings beyond slots and addresses, grouped.
    struct EngineSettings {
        std::optional<Remote> spectate;  // spectator(): slot 0's address; .slot holds the index
        bool spectate_server = false;    // spectator() with no address: through server()
        int spectators = 0;
        std::optional<std::vector<std::uint8_t>> token;  // connect_token()
        bool join = false;
        rollback::SessionObserver* observer = nullptr;
        std::string desync_report_dir;
        std::string replay_path, replay_scene;
        std::optional<std::uint64_t> interrupt_ms, disconnect_ms;
    };
    EngineSettings engine_;
};

}  // namespace lockroll::net
