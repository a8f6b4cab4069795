#include "harness/proxy_command.h"

#include <csignal>
#include <cstdio>
#include <memory>
#include <string>

#include "harness/cli_error.h"
#include "harness/match.h"
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

void run_proxy(const Options& o) {
    net::UdpProxyConfig config;
    config.listen = loopback_address("--listen", o.listen, true);
    config.upstream = loopback_address("--to", o.to, false);
    if (config.upstream.port() == 0) throw UsageError("--to '" + o.to + "': port must not be 0");
    validate(o.net);
    if (!(o.duration_s >= 0 && o.duration_s <= 1e6)) throw UsageError("--duration-s must be 0..1000000 seconds");
    config.link = link_for(o.net);
    config.seed = o.seed;

    install_stop_handlers();
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
                 "queue_full %llu clients %llu refused_clients %llu socket_errors %llu\n",
                 static_cast<unsigned long long>(c.received), static_cast<unsigned long long>(c.forwarded),
                 static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.duplicated),
                 static_cast<unsigned long long>(c.reordered), static_cast<unsigned long long>(c.queue_full),
                 static_cast<unsigned long long>(c.clients), static_cast<unsigned long long>(c.refused_clients),
                 static_cast<unsigned long long>(c.socket_errors));
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
    cmd->callback([o] { run_proxy(*o); });
}

}  // namespace lockroll::harness
