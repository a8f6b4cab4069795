// relay_cost: what one relayed datagram costs the server, countable on a busy machine.
//
// relay_bench measures the server as a process (delay, CPU share), which a shared machine's
// other jobs disturb. This driver runs the server's own per-pass code (server::ServerPass over
// transport::EnetServer and server::RelayServer, as lockroll-server does after each poll) in
// one process with R two-player rooms of bot clients on loopback, under a virtual clock: the
// room clocks, the bots' 60 Hz ticks and ENet's own timers (enet_time_set) follow the driver's
// time, not the wall clock. So the work per datagram is the same however slowly it runs, and
// valgrind's callgrind counts its instructions repeatably:
//
//   valgrind --tool=callgrind --toggle-collect=relay_cost_server_pass build/bench/relay_cost --rooms 200
//
// counts only the server's passes (poll + ServerPass::run) over the measured ticks; divide by
// the relay datagrams in + out it prints. Kernel time is not in callgrind's count; the server
// socket's syscalls per relayed datagram are printed instead, counted in this process by
// server/enet_socket_batching (the same interposer lockroll-server runs): --syscalls batch (as
// lockroll-server: recvmmsg / sendmmsg) or --syscalls enet (ENet's own, one per datagram, counted).
// Without valgrind it also prints the wall time per datagram (indicative only).
//
// ENet's clock is the driver's too: this executable defines enet_time_get (libenet calls its own
// through the PLT, as it does its socket functions), returning the virtual time. ENet's
// enet_time_set only rebased its wall clock, which went on running while a step ran: under
// callgrind a step of a thousand rooms takes seconds, and acknowledgements stamped "in the
// future" of their host's clock were dropped (connections timed out, rooms did not start once
// the server serviced its hosts at different points of a step). It still reads the clock as
// ENet's does (gettimeofday), so the count keeps that cost.
//
// The bots behave like relay_bench's: one RelayInput per client per tick with an input delay
// of 2 frames, the unacknowledged own inputs resent, the room's clients sending in the same
// tick phase; rooms are spread over --phases phases of the tick, one server pass per phase.
#include <CLI/CLI.hpp>
#include <enet/enet.h>

#include <sys/time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "rollback/relay_messages.h"
#include "server/enet_socket_batching.h"
#include "server/relay_server.h"
#include "server/server_pass.h"
#include "server/server_process.h"
#include "transport/enet_server.h"

namespace {

using namespace lockroll;
using namespace lockroll::rollback;

constexpr int kPlayers = 2;
constexpr std::size_t kInputSize = 3;
constexpr int kTickRate = 60;
constexpr std::uint64_t kPeriodUs = 1000000 / kTickRate;
constexpr std::uint32_t kMaxResend = 8;
constexpr int kInputDelay = 2;

struct Bot {
    ENetPeer* peer = nullptr;
    int room = 0;
    int slot = 0;
    bool welcomed = false;
    bool has_clock = false;
    std::uint32_t server_frame = 0;
    std::uint32_t input_ack = 0;
    std::uint32_t confirmed_next = 0;
};

struct Counts {
    std::uint64_t relay_in = 0, relay_out = 0, udp_in = 0, udp_out = 0, passes = 0, syscalls = 0;
    std::uint64_t host_services = 0, host_flushes = 0, idle_services = 0;
};

}  // namespace

namespace {
enet_uint32 g_enet_ms = 0;  // ENet's clock (enet_time_get below), in ms of the driver's time
}  // namespace

extern "C" enet_uint32 enet_time_get(void) {
    timeval tv;
    gettimeofday(&tv, nullptr);  // ENet's own reads the wall clock: its cost stays in the count
    asm volatile("" : : "r"(&tv) : "memory");
    return g_enet_ms;
}
extern "C" void enet_time_set(enet_uint32 ms) { g_enet_ms = ms; }

namespace {
// One poll of the server's socket and one pass of its loop, as lockroll-server without a pass
// interval (server/server_process.cpp), the batch flushed after each.
void server_pass_body(transport::EnetServer& enet, server::RelayServer& relay, server::ServerPass& pass, std::uint64_t now) {
    enet.poll(now, 0);
    server::enet_socket_batching::flush();
    pass.run(enet, relay, now, nullptr, false);
    server::enet_socket_batching::flush();
}
}  // namespace

// The measured work (the passes of the measured ticks only). Not inlined, so callgrind's
// --toggle-collect can name it.
extern "C" __attribute__((noinline)) void relay_cost_server_pass(transport::EnetServer& enet, server::RelayServer& relay,
                                                                  server::ServerPass& pass, std::uint64_t now) {
    server_pass_body(enet, relay, pass, now);
}

namespace {

class Driver {
public:
    Driver(int rooms, int phases, server::enet_socket_batching::Mode mode, std::size_t per_host)
        : rooms_(rooms), phases_(std::max(1, std::min(phases, rooms))) {
        transport::EnetServerConfig ec;
        ec.max_connections = static_cast<std::size_t>(std::min(4095, 2 * rooms + 64));
        ec.max_connections_per_address = 4095;
        if (mode == server::enet_socket_batching::Mode::Batch && per_host > 0) {  // as lockroll-server
            ec.fanout = &server::enet_socket_batching::fanout();
            ec.connections_per_host = per_host;
        }
        enet_ = std::make_unique<transport::EnetServer>(ec);
        if (!enet_->fanout_refused().empty()) throw std::runtime_error("cannot share the server socket: " + enet_->fanout_refused());
        if (enet_->host_count() == 1) {
            const std::string why = server::enet_socket_batching::install(enet_->socket_fd(), mode);
            if (!why.empty()) throw std::runtime_error("cannot count the server socket's syscalls: " + why);
        }
        server::ServerConfig sc;
        sc.max_rooms = static_cast<std::size_t>(rooms + 16);
        sc.max_connections = ec.max_connections;
        relay_ = std::make_unique<server::RelayServer>(sc);
        ENetAddress a{};
        enet_address_set_host(&a, "127.0.0.1");
        a.port = enet_->port();
        for (int h = 0; h < phases_; ++h) {
            ENetHost* host = enet_host_create(nullptr, static_cast<std::size_t>(2 * (rooms / phases_ + 1)), 2, 0, 0);
            if (!host) throw std::runtime_error("enet_host_create failed");
            host->duplicatePeers = ENET_PROTOCOL_MAXIMUM_PEER_ID;
            enet_socket_set_option(host->socket, ENET_SOCKOPT_RCVBUF, 1 << 20);
            hosts_.push_back(host);
        }
        bots_.resize(static_cast<std::size_t>(rooms) * kPlayers);
        next_frame_.assign(static_cast<std::size_t>(rooms), 0);
        for (int r = 0; r < rooms; ++r)
            for (int s = 0; s < kPlayers; ++s) {
                Bot& b = bots_[static_cast<std::size_t>(r * kPlayers + s)];
                b.room = r;
                b.slot = s;
                b.peer = enet_host_connect(hosts_[static_cast<std::size_t>(r % phases_)], &a, 2, 0);
                if (!b.peer) throw std::runtime_error("enet_host_connect failed");
                b.peer->data = &b;
            }
    }
    ~Driver() {
        for (auto* h : hosts_) enet_host_destroy(h);
    }

    // Connects every bot and starts every room (virtual time, 1 ms steps).
    bool start() {
        for (int step = 0; step < 20000; ++step) {
            now_ += 1000;
            set_enet_time();
            server_pass();
            for (int h = 0; h < phases_; ++h) service(h);
            bool all = true;
            for (const auto& b : bots_) all = all && b.welcomed && b.has_clock;
            if (all) return true;
            if (step % 16 == 0)  // waiting clients still talk (heartbeats)
                for (auto& b : bots_)
                    if (b.welcomed) send_input(b, 0, 0);
            for (auto* h : hosts_) enet_host_flush(h);
        }
        return false;
    }

    // One tick: each phase's rooms send their inputs, the server runs one pass, the bots read.
    void tick(bool measured) {
        measuring_ = measured;
        const std::uint64_t tick_start = now_;
        for (int h = 0; h < phases_; ++h) {
            now_ = tick_start + kPeriodUs * static_cast<std::uint64_t>(h) / static_cast<std::uint64_t>(phases_);
            set_enet_time();
            for (int r = h; r < rooms_; r += phases_) {
                auto& next = next_frame_[static_cast<std::size_t>(r)];
                Bot* room_bots = &bots_[static_cast<std::size_t>(r * kPlayers)];
                if (next == 0) next = room_bots[0].server_frame + 1 + kInputDelay;
                const std::uint32_t f = next++;
                for (int s = 0; s < kPlayers; ++s) {
                    Bot& b = room_bots[s];
                    const std::uint32_t first = std::min(f, std::max(b.input_ack, f + 1 - std::min(f + 1, kMaxResend)));
                    send_input(b, first, f + 1 - first);
                }
            }
            enet_host_flush(hosts_[static_cast<std::size_t>(h)]);
            if (measured) {
                relay_cost_server_pass(*enet_, *relay_, pass_, now_);
                ++passes_;
            } else {
                server_pass();
            }
            for (int g = 0; g < phases_; ++g) service(g);
        }
        now_ = tick_start + kPeriodUs;
    }

    Counts counts() const {
        Counts c;
        c.syscalls = server::enet_socket_batching::counts().syscalls();
        c.relay_in = relay_->counters().datagrams_in;
        c.relay_out = relay_->counters().datagrams_out;
        c.passes = passes_;
        c.host_services = enet_->counters().host_services;
        c.host_flushes = enet_->counters().host_flushes;
        c.idle_services = enet_->counters().idle_services;
        for (auto* h : hosts_) {
            c.udp_in += h->totalSentPackets;
            c.udp_out += h->totalReceivedPackets;
        }
        return c;
    }
    std::uint64_t replaced() const { return replaced_; }
    std::size_t hosts() const { return enet_->host_count(); }
    std::size_t connections() const { return enet_->connection_count(); }
    const transport::EnetServer& enet() const { return *enet_; }
    const server::RelayServer& relay() const { return *relay_; }
    std::size_t bots_welcomed() const {
        std::size_t n = 0;
        for (const auto& b : bots_) n += b.welcomed && b.has_clock;
        return n;
    }
    std::uint64_t disconnects() const { return disconnects_; }

private:
    void set_enet_time() { enet_time_set(static_cast<enet_uint32>(now_ / 1000)); }
    void server_pass() { server_pass_body(*enet_, *relay_, pass_, now_); }

    void send_input(Bot& b, std::uint32_t first, std::uint32_t count) {
        RelayInput& m = input_;
        m.confirmed_ack = b.confirmed_next;
        m.first_frame = first;
        m.frame_count = static_cast<std::uint8_t>(count);
        m.slots = static_cast<std::uint16_t>(1u << b.slot);
        m.inputs.resize(count * kInputSize);
        for (std::uint32_t i = 0; i < count; ++i) {
            const std::uint32_t phase = ((first + i) / 30 + static_cast<std::uint32_t>(b.room * 7 + b.slot * 3)) % 9;
            m.inputs[i * kInputSize] = static_cast<std::uint8_t>(static_cast<int>(phase % 3) - 1);
            m.inputs[i * kInputSize + 1] = static_cast<std::uint8_t>(static_cast<int>(phase / 3) - 1);
            m.inputs[i * kInputSize + 2] = 0;
        }
        m.stamp = static_cast<std::uint16_t>(now_ / 100);
        m.checksum_count = 0;
        bytes_.clear();
        encode(m, kInputSize, bytes_);
        enet_peer_send(b.peer, 0, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_UNSEQUENCED));
    }

    void send_hello(Bot& b) {
        RelayHello h;
        h.room_id = 0x10000 + static_cast<std::uint64_t>(b.room);
        h.scene_checksum = 0x5EED;
        h.players = kPlayers;
        h.input_size = kInputSize;
        h.tick_rate = kTickRate;
        h.slot = static_cast<std::uint8_t>(b.slot);
        h.stamp_us = now_;
        bytes_.clear();
        encode(h, bytes_);
        enet_peer_send(b.peer, 1, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_RELIABLE));
    }

    void service(int h) {
        ENetEvent e;
        while (enet_host_service(hosts_[static_cast<std::size_t>(h)], &e, 0) > 0) {
            Bot* b = e.peer ? static_cast<Bot*>(e.peer->data) : nullptr;
            if (e.type == ENET_EVENT_TYPE_CONNECT && b) {
                enet_peer_throttle_configure(e.peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
                send_hello(*b);
            } else if (e.type == ENET_EVENT_TYPE_DISCONNECT) {
                ++disconnects_;
            } else if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                if (b) on_datagram(*b, {e.packet->data, e.packet->dataLength});
                enet_packet_destroy(e.packet);
            }
        }
    }

    void on_datagram(Bot& b, std::span<const std::uint8_t> d) {
        const auto kind = peek_relay_kind(d);
        if (kind == RelayKind::Welcome) {
            b.welcomed = decode(d, welcome_) == nullptr && welcome_.refusal == RelayRefusal::None;
        } else if (kind == RelayKind::Frames && decode(d, kPlayers, kInputSize, frames_) == nullptr) {
            b.has_clock = true;
            b.server_frame = frames_.server_frame;
            b.input_ack = std::max(b.input_ack, frames_.input_ack);
            const std::uint32_t end = frames_.first_frame + frames_.frame_count;
            for (std::uint32_t f = std::max(b.confirmed_next, frames_.first_frame); f < end; ++f)
                if (measuring_ && b.slot == 0 && (frames_.flags[(f - frames_.first_frame) * kPlayers] & kRelayReplaced)) ++replaced_;
            if (frames_.first_frame <= b.confirmed_next) b.confirmed_next = std::max(b.confirmed_next, end);
        }
    }

    int rooms_, phases_;
    std::uint64_t now_ = 1'000'000;
    std::unique_ptr<transport::EnetServer> enet_;
    std::unique_ptr<server::RelayServer> relay_;
    server::ServerPass pass_;
    std::vector<ENetHost*> hosts_;
    std::vector<Bot> bots_;
    std::vector<std::uint32_t> next_frame_;
    std::vector<std::uint8_t> bytes_;
    RelayInput input_;
    RelayFrames frames_;
    RelayWelcome welcome_;
    std::uint64_t passes_ = 0, replaced_ = 0, disconnects_ = 0;
    bool measuring_ = false;
};

}  // namespace

int main(int argc, char** argv) {
    int rooms = 200, phases = 16, warm_ticks = 60, ticks = 300;
    std::size_t per_host = server::kDefaultConnectionsPerHost;
    std::string syscalls = "batch";
    CLI::App app{"relay_cost: the server's work per relayed datagram, under a virtual clock (docs/performance.md)"};
    app.add_option("--rooms", rooms, "two-player rooms")->check(CLI::Range(1, 2000))->capture_default_str();
    app.add_option("--phases", phases, "tick phases (one server pass each)")->check(CLI::Range(1, 256))->capture_default_str();
    app.add_option("--warm-ticks", warm_ticks, "ticks played before measuring")->check(CLI::Range(1, 100000))->capture_default_str();
    app.add_option("--ticks", ticks, "ticks measured")->check(CLI::Range(1, 100000))->capture_default_str();
    app.add_option("--syscalls", syscalls, "the server socket's syscalls: batch (recvmmsg / sendmmsg, as lockroll-server) or enet (one per datagram)")
        ->check(CLI::IsMember({"batch", "enet"}))
        ->capture_default_str();
    app.add_option("--connections-per-host", per_host,
                   "connections per ENet host behind the server's socket, as lockroll-server's option (batch only; 0: one host)")
        ->check(CLI::Range(0, 4095))
        ->capture_default_str();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;  // a bad flag: exit 2, as every lockroll program
    }
    const auto mode = syscalls == "batch" ? server::enet_socket_batching::Mode::Batch : server::enet_socket_batching::Mode::Count;
    if (enet_initialize() != 0) return 1;
    int status = 0;
    {
        Driver d(rooms, phases, mode, per_host);
        if (!d.start()) {
            std::fprintf(stderr, "relay_cost: the rooms did not all start (server connections %zu, bots welcomed %zu; server connects %llu, "
                         "disconnects %llu, kicks %llu)\n",
                         d.connections(), d.bots_welcomed(), static_cast<unsigned long long>(d.enet().counters().connections),
                         static_cast<unsigned long long>(d.enet().counters().disconnects),
                         static_cast<unsigned long long>(d.relay().counters().kicks));
            return 1;
        }
        for (int t = 0; t < warm_ticks; ++t) d.tick(false);
        const Counts a = d.counts();
        const auto t0 = std::chrono::steady_clock::now();
        for (int t = 0; t < ticks; ++t) d.tick(true);
        const double wall_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
        const Counts b = d.counts();
        const std::uint64_t relay = (b.relay_in - a.relay_in) + (b.relay_out - a.relay_out);
        const std::uint64_t udp = (b.udp_in - a.udp_in) + (b.udp_out - a.udp_out);
        std::printf("ENet hosts behind the server's socket: %zu\n", d.hosts());
        std::printf("rooms %d, phases %d, ticks %d: relay datagrams in %llu out %llu (%.1f per room-tick), UDP datagrams %llu, "
                    "server passes %llu, inputs replaced while measured %llu, disconnects %llu\n",
                    rooms, phases, ticks, static_cast<unsigned long long>(b.relay_in - a.relay_in),
                    static_cast<unsigned long long>(b.relay_out - a.relay_out), static_cast<double>(relay) / rooms / ticks,
                    static_cast<unsigned long long>(udp), static_cast<unsigned long long>(b.passes - a.passes),
                    static_cast<unsigned long long>(d.replaced()), static_cast<unsigned long long>(d.disconnects()));
        std::printf("relay datagrams measured: %llu (divide callgrind's Ir of relay_cost_server_pass by this)\n",
                    static_cast<unsigned long long>(relay));
        std::printf("server socket syscalls (%s) while measured: %llu, %.3f per relay datagram\n", syscalls.c_str(),
                    static_cast<unsigned long long>(b.syscalls - a.syscalls), static_cast<double>(b.syscalls - a.syscalls) / static_cast<double>(relay));
        std::printf("ENet host services per pass %.1f (idle %.1f), host flushes per pass %.1f\n",
                    static_cast<double>(b.host_services - a.host_services) / static_cast<double>(b.passes - a.passes),
                    static_cast<double>(b.idle_services - a.idle_services) / static_cast<double>(b.passes - a.passes),
                    static_cast<double>(b.host_flushes - a.host_flushes) / static_cast<double>(b.passes - a.passes));
        std::printf("wall time (bots included, indicative): %.2f us per relay datagram\n", wall_us / static_cast<double>(relay));
        if (d.replaced() || d.disconnects()) status = 1;
    }
    enet_deinitialize();
    return status;
}
