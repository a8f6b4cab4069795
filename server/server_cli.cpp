#include "server/server_cli.h"

#include <memory>
#include <string>
#include <stdexcept>

#include "server/connect_token.h"
#include "server/server_process.h"

namespace lockroll::server {

void add_server_options(CLI::App& cmd, const SocketBatching& batching) {
    auto o = std::make_shared<ServerProcessOptions>();
    o->socket_batching = batching;
    cmd.add_option("--listen", o->listen, "HOST:PORT to listen on (port 0: any free one; printed as 'ready PORT')")
        ->capture_default_str()
        ->check([](const std::string& s) {
            try {
                std::string h;
                std::uint16_t p;
                parse_listen(s, h, p);
                return std::string();
            } catch (const std::exception& e) {
                return std::string(e.what());
            }
        });
    cmd.add_option("--input-deadline", o->server.room.input_deadline, "Ticks past a frame's time before late inputs are replaced")
        ->check(CLI::Range(1, 255))
        ->capture_default_str();
    cmd.add_option("--checksum-interval", o->server.room.checksum_interval, "Arbitrate confirmed checksums every K frames (0: off)")
        ->check(CLI::Range(0, 65535))
        ->capture_default_str();
    cmd.add_option_function<std::string>(
           "--two-player-desync",
           [o](const std::string& v) {
               o->server.room.two_player_desync = v == "end" ? TwoPlayerDesync::EndMatch : TwoPlayerDesync::KeepLowestSlot;
           },
           "Two players whose checksums disagree (no majority): end (the match ends for both) or keep-lowest (P2P's "
           "DesyncKeep::LowestSlot: the higher slot reloads from the lower)")
        ->check(CLI::IsMember({"end", "keep-lowest"}))
        ->default_str("end");
    cmd.add_option("--max-minority-rounds", o->server.room.max_minority_rounds,
                   "Checksum rounds in a row a client may be outvoted by a majority (3+ voters) before it is kicked (0: never)")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    cmd.add_option("--history-s", o->server.room.history_s, "Seconds of confirmed input history kept per room (late join, reconnect)")
        ->check(CLI::Range(1.0, 86400.0))
        ->capture_default_str();
    cmd.add_option("--max-rooms", o->server.max_rooms, "Rooms this process accepts at once")->check(CLI::Range(1, 100000))->capture_default_str();
    cmd.add_option("--max-connections", o->server.max_connections,
                   "Connections this process accepts at once (size it to rooms x (players + spectators): with one ENet host, ENet walks every slot on each pass)")
        ->check(CLI::Range(2, 4095))
        ->capture_default_str();
    cmd.add_option("--max-spectators", o->server.room.max_spectators, "Spectator places per room")->check(CLI::Range(0, 64))->capture_default_str();
    cmd.add_option("--per-address", o->max_connections_per_address, "Connections one IP address may hold (raise for a load test)")
        ->check(CLI::Range(1, 4095))
        ->capture_default_str();
    cmd.add_option("--connections-per-host", o->connections_per_host,
                   "Connections per ENet host behind the one socket (lockroll-server, batched syscalls only): a pass services only "
                   "the hosts with traffic, instead of walking every connection; 0: one host for all (as lockroll server)")
        ->check(CLI::Range(0, 4095))
        ->capture_default_str();
    cmd.add_option("--pass-interval-us", o->pass_interval_us,
                   "Shortest time between two passes of the loop (0: a pass per wake-up). Each pass services the ENet hosts with "
                   "traffic (with one host: walks every connection slot three times); a longer interval batches more datagrams "
                   "per pass, for up to this much more relay delay")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    // Read here, while parsing: a missing or malformed key file exits 2 before anything binds.
    cmd.add_option_function<std::string>(
           "--key",
           [o](const std::string& path) {
               try {
                   o->server.token_key = read_token_key(path);
                   o->key_file = path;
               } catch (const std::invalid_argument& e) {
                   throw CLI::ValidationError("--key", e.what());
               }
           },
           "FILE with the 64-hex-digit key shared with the backend (lockroll token --new-key): admit only hellos with a "
           "valid connect token sealed with it. Without it anyone who names a room may create it or take a free slot")
        ->type_name("FILE");
    cmd.add_option("--ready-file", o->ready_file, "Write the bound port here once listening");
    cmd.add_option("--status-file", o->status_file, "Rewrite this JSON health/status file every second");
    cmd.add_option("--drain-timeout", o->drain_timeout_s, "Seconds a drain may take before the process gives up (exit 3)")
        ->check(CLI::Range(0.1, 86400.0))
        ->capture_default_str();
    cmd.add_option("--run-seconds", o->run_seconds, "Drain after this many seconds (0: run until SIGTERM)")
        ->check(CLI::Range(0.0, 1e7))
        ->capture_default_str();
    cmd.add_option("--log-level", o->log_level, "trace, debug, info, warn, error, critical or off")
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
        ->capture_default_str();
    cmd.callback([o] {
        const int status = run_server_process(*o);
        if (status != 0) throw std::runtime_error("the drain timed out with rooms still open");
    });
}

}  // namespace lockroll::server
