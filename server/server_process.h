// The relay server as a process: RelayServer bound to EnetServer and the monotonic clock (this
// file and net/clock.h are the only places lockroll reads a clock), with what a game-server
// orchestrator such as Agones needs (docs/deployment.md):
//  - ready: once listening, a line "ready PORT" on stdout and, if asked, a ready file;
//  - health: a status file rewritten atomically every second (state, rooms, connections,
//    counters): a liveness probe checks that it is fresh, a readiness probe that it says ready;
//    written by a thread of its own (server/status_writer.h): the loop never waits on the disk;
//  - drain on SIGTERM (or request_drain()): new hellos are refused with the reason, running rooms
//    play to their end, and the process exits 0 once the last room closed (or after
//    drain_timeout_s, exiting 3);
//  - a room limit (ServerConfig::max_rooms);
//  - a log off the loop (server/server_log.h): a stderr nobody reads drops lines, never stops
//    the rooms.
// The loop waits in the socket for the first datagram (no busy spin), handles everything that
// arrived, ticks the rooms, and flushes what they queued: a relay delay of one pass.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "server/relay_server.h"

namespace lockroll::transport {
class SocketFanout;
}

namespace spdlog {
class logger;
}

namespace lockroll::server {

// lockroll-server's batched socket syscalls (server/enet_socket_batching.h), given by its main;
// empty in `lockroll server`, which keeps ENet's one syscall per datagram. install gets the bound
// socket and returns "" or why batching is off; flush sends what ENet queued (run after each poll
// and each pass).
// fanout, when set, lets several ENet hosts share the socket (transport::SocketFanout; it batches
// the socket itself, install is then not called).
struct SocketBatching {
    std::function<std::string(int fd)> install;
    std::function<void()> flush;
    std::function<transport::SocketFanout*()> fanout;
};

// Connections per ENet host when the socket is shared (ServerProcessOptions::connections_per_host;
// docs/performance.md, "Density": the walks a pass makes grow with the hosts it services times
// their size, and each serviced host costs a few hundred instructions of its own).
inline constexpr std::size_t kDefaultConnectionsPerHost = 4;

struct ServerProcessOptions {
    std::string listen = "127.0.0.1:0";
    ServerConfig server;
    std::size_t max_connections_per_address = 64;
    std::string ready_file;    // written with the port once listening
    std::string status_file;   // JSON, rewritten every second
    double drain_timeout_s = 900;
    double run_seconds = 0;    // > 0: drain after this long (tests, soak)
    // Shortest time between two passes (0: one per wake-up). With one ENet host a pass walks every
    // connection slot three times whatever it carries; with several (connections_per_host) it
    // services the hosts with traffic, each at a fixed cost: waiting a little batches more
    // datagrams per pass either way.
    std::uint32_t pass_interval_us = 0;
    // Connections per ENet host behind the socket, when socket_batching has a fanout (0: one host).
    std::size_t connections_per_host = kDefaultConnectionsPerHost;
    std::string log_level = "info";
    std::string key_file;      // where server.token_key came from (for the log)
    SocketBatching socket_batching;
};

// HOST:PORT or [V6]:PORT; throws std::invalid_argument naming the text.
void parse_listen(const std::string& text, std::string& host, std::uint16_t& port);

class ServerProcess {
public:
    explicit ServerProcess(const ServerProcessOptions& options);  // throws on bad options
    // Runs until drained. 0: drained cleanly; 3: drain timed out.
    int run();
    void request_drain() { drain_.store(true, std::memory_order_relaxed); }
    static ServerProcess* signal_target();

private:
    ServerProcessOptions options_;
    std::atomic<bool> drain_{false};
};

// Installs SIGTERM / SIGINT handlers that drain the running ServerProcess, ignores SIGPIPE (a
// log whose reader went away loses lines, not the process), then runs it.
int run_server_process(const ServerProcessOptions& options);

}  // namespace lockroll::server
