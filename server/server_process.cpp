#include "server/server_process.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <thread>

#include "server/server_log.h"
#include "server/server_pass.h"
#include "server/status_writer.h"
#include "transport/enet_server.h"

namespace lockroll::server {

namespace {
std::atomic<ServerProcess*> g_process{nullptr};

void on_signal(int) {
    if (ServerProcess* p = g_process.load()) p->request_drain();
}

std::uint64_t monotonic_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
}

// The wall clock, for connect tokens' expiry only (Unix microseconds).
std::uint64_t unix_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

std::string status_json(const RelayServer& s, const transport::EnetServer& enet, const ServerLog& log, bool draining, double uptime_s) {
    const ServerCounters& c = s.counters();
    auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
    char buf[1200];
    std::snprintf(buf, sizeof buf,
                  "{\"state\": \"%s\", \"port\": %u, \"uptime_s\": %.1f, \"rooms\": %zu, \"connections\": %zu, "
                  "\"rooms_created\": %llu, \"rooms_closed\": %llu, \"hellos_refused\": %llu, \"tokens_refused\": %llu, "
                  "\"token_replays\": %llu, \"bad_packets\": %llu, "
                  "\"throttled\": %llu, \"kicks\": %llu, \"datagrams_in\": %llu, \"datagrams_out\": %llu, "
                  "\"bytes_in\": %llu, \"bytes_out\": %llu, \"wire_bytes_in\": %llu, \"wire_bytes_out\": %llu, \"log_dropped\": %llu}\n",
                  draining ? "draining" : "ready", enet.port(), uptime_s, s.room_count(), s.connection_count(), u(c.rooms_created),
                  u(c.rooms_closed), u(c.hellos_refused), u(c.tokens_refused), u(c.token_replays), u(c.bad_packets), u(c.throttled), u(c.kicks), u(c.datagrams_in),
                  u(c.datagrams_out), u(c.bytes_in), u(c.bytes_out), u(enet.wire_bytes_received()), u(enet.wire_bytes_sent()), u(log.dropped()));
    return buf;
}
}  // namespace

void parse_listen(const std::string& text, std::string& host, std::uint16_t& port) {
    const auto colon = text.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
        throw std::invalid_argument("'" + text + "' is not HOST:PORT");
    host = text.substr(0, colon);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
    const std::string p = text.substr(colon + 1);
    if (p.find_first_not_of("0123456789") != std::string::npos || p.size() > 5 || std::stoul(p) > 65535)
        throw std::invalid_argument("'" + text + "': port must be 0..65535");
    port = static_cast<std::uint16_t>(std::stoul(p));
}

ServerProcess::ServerProcess(const ServerProcessOptions& options) : options_(options) {
    validate(options_.server);
    std::string host;
    std::uint16_t port = 0;
    parse_listen(options_.listen, host, port);
    if (!(options_.drain_timeout_s > 0)) throw std::invalid_argument("drain timeout must be positive");
}

ServerProcess* ServerProcess::signal_target() { return g_process.load(); }

int ServerProcess::run() {
    // Off the loop, bounded (server/server_log.h): a stderr nobody reads never stops the rooms.
    // Closed on every return (its destructor): what is queued is written, within a bound.
    ServerLog log(options_.log_level);
    std::string host;
    std::uint16_t port = 0;
    parse_listen(options_.listen, host, port);
    transport::EnetServerConfig ec;
    ec.bind_host = host;
    ec.port = port;
    ec.max_connections = std::min<std::size_t>(options_.server.max_connections, 4095);
    ec.max_connections_per_address = options_.max_connections_per_address;
    const SocketBatching& batching = options_.socket_batching;
    if (batching.fanout && options_.connections_per_host > 0 && (ec.fanout = batching.fanout()) != nullptr) {
        ec.connections_per_host = options_.connections_per_host;
    }
    transport::EnetServer enet(ec);
    RelayServer server(options_.server);
    const auto flush_batch = [&] {
        if (batching.flush) batching.flush();
    };
    if (enet.host_count() > 1) {
        log->info("socket syscalls batched: recvmmsg / sendmmsg under ENet; {} ENet hosts of {} connections share the socket",
                  enet.host_count(), options_.connections_per_host);
    } else if (batching.install) {
        if (!enet.fanout_refused().empty()) log->warn("one ENet host for every connection ({})", enet.fanout_refused());
        const std::string why = batching.install(enet.socket_fd());
        if (why.empty())
            log->info("socket syscalls batched: recvmmsg / sendmmsg under ENet");
        else
            log->warn("socket syscalls not batched ({}): one per datagram, as plain ENet", why);
    }
    const std::uint64_t start = monotonic_us();
    server.set_wall_clock(unix_us(), start);
    if (options_.server.token_key)
        log->info("connect tokens required: a hello needs a valid, unexpired token sealed with the key in {}", options_.key_file);
    else
        log->warn("no --key: connect tokens off, rooms are open (anyone who names a room may create it or take a free slot)");
    log->info("listening on {}:{} (room limit {}, input deadline {} ticks, checksum interval {}, history {} s)", host,
              enet.port(), options_.server.max_rooms, options_.server.room.input_deadline,
              options_.server.room.checksum_interval, options_.server.room.history_s);
    // Once, before the first pass: the ready file may wait on the filesystem; the status file,
    // rewritten every second while rooms play, never makes the loop wait (StatusWriter).
    if (!options_.ready_file.empty()) write_file_replacing(options_.ready_file, std::to_string(enet.port()) + "\n");
    std::optional<StatusWriter> status;
    if (!options_.status_file.empty()) status.emplace(options_.status_file);
    std::printf("ready %u\n", enet.port());
    std::fflush(stdout);

    ServerPass pass;
    std::uint64_t next_status = 0, drain_started = 0;
    std::uint64_t last_pass = 0;
    for (;;) {
        if (options_.pass_interval_us > 0) {
            const std::uint64_t t = monotonic_us();
            if (t < last_pass + options_.pass_interval_us)
                std::this_thread::sleep_for(std::chrono::microseconds(last_pass + options_.pass_interval_us - t));
        }
        last_pass = monotonic_us();
        enet.poll(last_pass, 1000);
        flush_batch();
        const std::uint64_t now = monotonic_us();
        // Polling again at once sends what the pass queued; sleeping first (a pass interval) does not.
        pass.run(enet, server, now, &log.logger(), options_.pass_interval_us > 0);
        flush_batch();
        if (options_.run_seconds > 0 && now - start >= static_cast<std::uint64_t>(options_.run_seconds * 1e6)) request_drain();
        if (drain_.load(std::memory_order_relaxed) && !server.draining()) {
            log->info("draining: refusing new hellos; {} rooms play on", server.room_count());
            server.start_drain(now);
            drain_started = now;
        }
        if (now >= next_status) {
            next_status = now + 1000000;
            server.set_wall_clock(unix_us(), now);  // follows wall-clock steps within a second
            if (status) status->post(status_json(server, enet, log, server.draining(), static_cast<double>(now - start) / 1e6));
            log.report_dropped();
        }
        if (server.drained()) {
            enet.flush();
            flush_batch();
            if (status) {
                status->post(status_json(server, enet, log, true, static_cast<double>(now - start) / 1e6));
                status->wait_written();  // the last status is on disk before the exit
            }
            log.report_dropped();
            log->info("drained: every room finished; exiting");
            log.close();
            return 0;
        }
        if (drain_started && now - drain_started > static_cast<std::uint64_t>(options_.drain_timeout_s * 1e6)) {
            log.report_dropped();
            log->error("drain timed out with {} rooms still open", server.room_count());
            log.close();
            return 3;
        }
    }
}

int run_server_process(const ServerProcessOptions& options) {
    ServerProcess p(options);
    g_process.store(&p);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    // A log reader that goes away (a supervisor or journald restarting) must not end the rooms:
    // a write to a pipe with no reader fails with EPIPE, that line is lost, the loop plays on.
    std::signal(SIGPIPE, SIG_IGN);
    const int status = p.run();
    g_process.store(nullptr);
    return status;
}

}  // namespace lockroll::server
