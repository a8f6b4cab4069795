// A game that owns its loop: one player of a 2-player match, drawing at its own rate and calling
// NetSession::update() once per drawn frame (never run()). For tests/net/game_loop_test.sh.
//
//   game_loop_peer SLOT MY_PORT PEER_PORT FRAMES RENDER_HZ [enet|udp]
//
// enet (the default) is the builder's own ENet transport; udp is examples/counter's
// UdpSocketTransport (plain UDP sockets), handed to the builder with transport(). The game is a
// counter mixed with both players' scripted inputs. At the end it prints one line:
//   slot S outcome O final CHECKSUM updates U ticks T most_per_update M idle_updates I
//        interpolation_ok B transport T sent N shown F
// (the confirmed checksum of frame FRAMES; updates that ran no tick; whether every update's
// interpolation fraction was in [0, 1)). Exit 0 when the run completed with a checksum, 1 when
// not, 2 for bad arguments (before anything is bound).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>

#include "net/session_builder.h"
#include "rollback/simulation.h"
#include "udp_socket_transport.h"

namespace {

using lockroll::rollback::PlayerId;

class Counter final : public lockroll::rollback::Simulation {
public:
    using Simulation::step;
    void step(std::span<const std::uint8_t> in) override {
        for (std::size_t p = 0; p < in.size(); ++p) v_ = v_ * 1099511628211ull + in[p] + p + 1;
    }
    std::size_t state_size() const override { return 8; }
    void save(std::span<std::uint8_t> out) const override {
        for (std::size_t i = 0; i < 8; ++i) out[i] = static_cast<std::uint8_t>(v_ >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() != 8) return "a counter state is 8 bytes";
        v_ = 0;
        for (std::size_t i = 0; i < 8; ++i) v_ |= std::uint64_t{in[i]} << (8 * i);
        return {};
    }

private:
    std::uint64_t v_ = 0;
};

int usage(const std::string& why) {
    std::fprintf(stderr, "game_loop_peer: %s\nusage: game_loop_peer SLOT(0|1) MY_PORT PEER_PORT FRAMES RENDER_HZ [enet|udp]\n", why.c_str());
    return 2;
}

long number(const char* arg, const char* what, long lo, long hi) {
    char* end = nullptr;
    const long v = std::strtol(arg, &end, 10);
    if (end == arg || *end != '\0' || v < lo || v > hi)
        throw std::invalid_argument(std::string(what) + " " + arg + ": must be " + std::to_string(lo) + ".." + std::to_string(hi));
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 6 && argc != 7) return usage("expected 5 or 6 arguments");
    const std::string kind = argc == 7 ? argv[6] : "enet";
    if (kind != "enet" && kind != "udp") return usage("transport " + kind + ": must be enet or udp");
    long slot = 0, my_port = 0, peer_port = 0, frames = 0, hz = 0;
    try {
        slot = number(argv[1], "SLOT", 0, 1);
        my_port = number(argv[2], "MY_PORT", 1, 65535);
        peer_port = number(argv[3], "PEER_PORT", 1, 65535);
        frames = number(argv[4], "FRAMES", 1, 100000);
        hz = number(argv[5], "RENDER_HZ", 1, 1000);
    } catch (const std::exception& e) {
        return usage(e.what());
    }
    const auto me = static_cast<PlayerId>(slot);

    Counter game;
    std::unique_ptr<lockroll::net::NetSession> net;
    try {
        lockroll::net::SessionBuilder b;
        b.players(2)
            .input_size(1)
            .local_player(me)
            .remote_player(static_cast<PlayerId>(1 - slot), "127.0.0.1", static_cast<std::uint16_t>(peer_port))
            .match_id(0x6a3e100)
            .frames(static_cast<std::uint32_t>(frames));
        if (kind == "udp")
            b.transport(std::make_unique<example::UdpSocketTransport>(me, static_cast<std::uint16_t>(my_port), 2));
        else
            b.listen("127.0.0.1", static_cast<std::uint16_t>(my_port));
        net = b.start(game);
    } catch (const std::exception& e) {
        return usage(e.what());
    }

    const lockroll::net::InputSource input = [slot](std::uint32_t frame, std::span<std::uint8_t> out) {
        out[0] = static_cast<std::uint8_t>((frame * 7 + static_cast<std::uint32_t>(slot) * 91) % 251);
    };
    // The game's own loop: one update() per drawn frame, then sleep until the next frame is due.
    using Clock = std::chrono::steady_clock;
    const auto frame_time = std::chrono::microseconds(1000000 / hz);
    auto next = Clock::now();
    long updates = 0, ticks = 0, idle = 0;
    int most = 0;
    bool interpolation_ok = true;
    lockroll::net::RunOutcome outcome{};
    for (;;) {
        const lockroll::net::UpdateResult r = net->update(input);
        ++updates;
        ticks += r.frames;
        most = std::max(most, r.frames);
        idle += r.frames == 0;
        interpolation_ok = interpolation_ok && r.interpolation >= 0.0 && r.interpolation < 1.0;
        if (r.outcome) {
            outcome = *r.outcome;
            break;
        }
        // (Drawing would blend the last two frames' states by r.interpolation here.)
        next += frame_time;
        const auto now = Clock::now();
        if (next < now) next = now;  // a late frame is not made up in a burst
        std::this_thread::sleep_until(next);
    }
    const auto checksum = net->confirmed_checksum(static_cast<std::uint32_t>(frames));
    std::printf("slot %ld outcome %s final %016llx updates %ld ticks %ld most_per_update %d idle_updates %ld interpolation_ok %d "
                "transport %s sent %llu shown %u\n",
                slot, lockroll::net::outcome_name(outcome), checksum ? static_cast<unsigned long long>(*checksum) : 0ull, updates,
                ticks, most, idle, interpolation_ok ? 1 : 0, kind.c_str(),
                static_cast<unsigned long long>(net->transport().counters().datagrams_sent), net->session().frame());
    return outcome == lockroll::net::RunOutcome::Completed && checksum ? 0 : 1;
}
