#include "harness/proxy_command.h"

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "harness/match/cli_error.h"
#include "harness/cli_validators.h"
#include "harness/live/loopback_address.h"
#include "harness/match/match.h"
#include "harness/partition_flag.h"
#include "net/clock.h"
#include "net/udp_proxy.h"

namespace lockroll::harness {

namespace {

struct Options {
    std::string listen;
    std::string to;
    NetConditions net;
    std::uint64_t seed = 1;
    double duration_s = 0;
    // --partition and what it needs: slots of the two ends of each link, the frame clock.
    std::vector<std::string> partitions;
    int players = 2;
    int tick_rate = 60;
    int slot = -1;                        // the server's slot
    std::vector<std::string> client_slots;  // SLOT=[HOST:]PORT
    std::uint64_t epoch_us = 0;           // 0: when the proxy starts
};

// Set by SIGTERM/SIGINT; lock-free, so safe to store from a signal handler.
std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_stop_signal(int) { g_stop.store(true); }

void install_stop_handlers() {
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;  // no SA_RESTART: ppoll returns EINTR and the loop sees the flag at once
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
}

net::UdpAddress loopback_address(const std::string& flag, const std::string& text, bool bare_port_ok) {
    std::string error;
    auto a = net::parse_udp_address(text, &error, bare_port_ok ? "127.0.0.1" : "");
    if (!a) throw UsageError(flag + " " + error);
    if (!a->is_loopback())
        throw UsageError(flag + " '" + text + "': only loopback addresses (127.0.0.0/8, ::1) are allowed");
    return *a;
}

// --partition, --slot, --client-slot into the config; everything checked before binding.
void configure_partitions(const Options& o, net::UdpProxyConfig& config) {
    if (o.players < 2 || o.players > 256) throw UsageError("--players must be 2..256");
    if (o.tick_rate < 1 || o.tick_rate > 1000) throw UsageError("--tick-rate must be 1..1000");
    const auto slot_in_range = [&](const std::string& flag, const std::string& text, long slot) {
        if (slot < 0 || slot >= o.players)
            throw UsageError(flag + " " + text + ": SLOT must be 0.." + std::to_string(o.players - 1) + " (--players " +
                             std::to_string(o.players) + ")");
        return static_cast<transport::PeerId>(slot);
    };
    if (o.slot != -1) config.upstream_slot = slot_in_range("--slot", std::to_string(o.slot), o.slot);
    for (const std::string& text : o.client_slots) {
        const auto [slot, address] = parse_slot_address(text, "--client-slot", "SLOT=[HOST:]PORT");
        const net::UdpAddress from = loopback_address("--client-slot", address, true);
        if (from.port() == 0) throw UsageError("--client-slot " + text + ": port must be 1..65535");
        config.client_slots.emplace_back(from, slot_in_range("--client-slot", text, slot));
    }
    config.partitions = parse_partitions(o.partitions, o.players, o.tick_rate);
    if (!config.partitions.empty() && !config.upstream_slot)
        throw UsageError("--partition needs --slot (the slot of the server behind --to)");
}

void run_proxy(const Options& o) {
    net::UdpProxyConfig config;
    config.listen = loopback_address("--listen", o.listen, true);
    config.upstream = loopback_address("--to", o.to, false);
    if (config.upstream.port() == 0) throw UsageError("--to '" + o.to + "': port must not be 0");
    validate(o.net);
    if (!(o.duration_s >= 0 && o.duration_s <= 1e6)) throw UsageError("--duration-s must be 0..1000000 seconds");
    config.link = link_for(o.net);
    config.seed = o.seed;
    configure_partitions(o, config);

    install_stop_handlers();
    // Frame 0 of --partition: the given monotonic time (one for all of a run's proxies), or now.
    config.partition_epoch_us = o.epoch_us != 0 ? o.epoch_us : net::now_us();
    net::UdpProxy proxy(config);
    // With --listen 0 this names the port the OS chose: scripts and tests read it from here.
    std::printf("lockroll proxy: listening on %s -> %s\n", config.listen.with_port(proxy.port()).to_string().c_str(),
                config.upstream.to_string().c_str());
    std::fflush(stdout);
    const std::uint64_t deadline =
        o.duration_s > 0 ? net::now_us() + static_cast<std::uint64_t>(o.duration_s * 1e6) : 0;
    proxy.run(g_stop, deadline);
    const net::UdpProxyCounters& c = proxy.counters();
    std::fprintf(stderr,
                 "lockroll proxy: received %llu forwarded %llu dropped %llu duplicated %llu reordered %llu "
                 "queue_full %llu clients %llu refused_clients %llu socket_errors %llu partitioned %llu\n",
                 static_cast<unsigned long long>(c.received), static_cast<unsigned long long>(c.forwarded),
                 static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.duplicated),
                 static_cast<unsigned long long>(c.reordered), static_cast<unsigned long long>(c.queue_full),
                 static_cast<unsigned long long>(c.clients), static_cast<unsigned long long>(c.refused_clients),
                 static_cast<unsigned long long>(c.socket_errors), static_cast<unsigned long long>(c.partitioned));
}

}  // namespace

void add_proxy_command(CLI::App& app) {
    auto o = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand(
        "proxy", "UDP impairment proxy on loopback: forwards --listen <-> --to through the simulated link model");
    cmd->add_option("--listen", o->listen, "[HOST:]PORT to receive clients on (loopback; 0 = any free port)")
        ->required();
    cmd->add_option("--to", o->to, "HOST:PORT of the server to forward to (loopback only)")->required();
    cmd->add_option("--latency", o->net.latency_ms, "One-way latency, ms, each direction")->capture_default_str();
    cmd->add_option("--jitter", o->net.jitter_ms, "Uniform jitter, +- ms per packet")->capture_default_str();
    cmd->add_option("--loss", o->net.loss, "Packet loss probability 0..1")->capture_default_str();
    cmd->add_option("--burst,--burst-loss", o->net.burst_loss,
                    "Probability per packet of entering a loss burst 0..1 (mean length 2)")
        ->capture_default_str();
    cmd->add_option("--duplicate", o->net.duplicate, "Duplication probability 0..1")->capture_default_str();
    cmd->add_option("--reorder", o->net.reorder, "Reordering probability 0..1")->capture_default_str();
    cmd->add_option("--seed", o->seed, "Seed of the link model")->capture_default_str();
    cmd->add_option("--duration-s", o->duration_s, "Stop after this many seconds (0: until SIGTERM/SIGINT)");
    cmd->add_option("--partition", o->partitions,
                    "SETS@FROM-UNTIL: drop datagrams between the server's --slot and a client's slot while a cut "
                    "separates them, frames counted from --epoch-us at --tick-rate (repeatable)");
    cmd->add_option("--players", o->players, "Slots are 0..players-1 (for --partition)")->capture_default_str();
    cmd->add_option("--tick-rate", o->tick_rate, "Frames per second of --partition")->capture_default_str();
    cmd->add_option("--slot", o->slot, "The slot of the server behind --to (for --partition)");
    cmd->add_option("--client-slot", o->client_slots,
                    "SLOT=[HOST:]PORT: the slot of the client sending from that address (repeatable; "
                    "clients without one are never cut)");
    cmd->add_option("--epoch-us", o->epoch_us,
                    "Monotonic time (us, CLOCK_MONOTONIC) of frame 0 for --partition; default: when the proxy starts")
        ->check(kNonNegativeInteger);
    cmd->callback([o] { run_proxy(*o); });
}

}  // namespace lockroll::harness
