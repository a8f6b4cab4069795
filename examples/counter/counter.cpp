// The smallest lockroll game: one integer, two players over ENet. Each frame every player may
// press (one byte of input); the counter grows by 1 and by each press times the player's weight.
//
//   counter SLOT MY_PORT PEER_PORT [FRAMES [enet|udp]]   e.g.  counter 0 7000 7001  &  counter 1 7001 7000
//
// udp plays over the game's own transport (udp_socket_transport.h: plain UDP sockets) instead of
// the builder's ENet; both sides must say the same.
//
// Both processes play FRAMES frames (default 300) on 127.0.0.1 and print the confirmed checksum
// of the last frame, which must be the same on both. The game owns its loop: it calls
// NetSession::update() once per frame of its own (100 a second), never run().
#include <lockroll/net/session_builder.h>
#include <lockroll/rollback/simulation.h>

#include "udp_socket_transport.h"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <span>
#include <string>
#include <thread>

namespace {

// The game: its whole state is one integer, saved as 8 little-endian bytes.
class Counter final : public lockroll::rollback::Simulation {
public:
    void step(std::span<const std::uint8_t> inputs) override {
        value_ += 1;
        for (std::size_t p = 0; p < inputs.size(); ++p) value_ += std::int64_t{inputs[p]} * static_cast<std::int64_t>(p + 2);
    }
    std::size_t state_size() const override { return 8; }
    void save(std::span<std::uint8_t> out) const override {
        for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(value_) >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() < 8) return "a counter state is 8 bytes";
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v |= std::uint64_t{in[static_cast<std::size_t>(i)]} << (8 * i);
        value_ = static_cast<std::int64_t>(v);
        return {};
    }
    std::int64_t value() const { return value_; }

private:
    std::int64_t value_ = 0;
};

int usage() {
    std::fprintf(stderr, "usage: counter SLOT(0|1) MY_PORT PEER_PORT [FRAMES [enet|udp]]\n");
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4 || argc > 6) return usage();
    const int slot = std::atoi(argv[1]);
    const long my_port = std::atol(argv[2]), peer_port = std::atol(argv[3]);
    const long frames = argc >= 5 ? std::atol(argv[4]) : 300;
    const std::string transport = argc == 6 ? argv[5] : "enet";
    if (transport != "enet" && transport != "udp") return usage();
    if ((slot != 0 && slot != 1) || my_port < 1 || my_port > 65535 || peer_port < 1 || peer_port > 65535 || frames < 1)
        return usage();
    const auto me = static_cast<lockroll::rollback::PlayerId>(slot);
    const auto other = static_cast<lockroll::rollback::PlayerId>(1 - slot);

    Counter game;
    std::unique_ptr<lockroll::net::NetSession> session;
    try {  // configuration errors throw here; nothing per tick does
        lockroll::net::SessionBuilder builder;
        builder.players(2)
            .input_size(1)
            .local_player(me)
            .remote_player(other, "127.0.0.1", static_cast<std::uint16_t>(peer_port))
            .match_id(0xc0117e4)
            .frames(static_cast<std::uint32_t>(frames));
        if (transport == "udp")  // the game's own transport, bound here (so no listen())
            builder.transport(std::make_unique<example::UdpSocketTransport>(me, static_cast<std::uint16_t>(my_port), 2));
        else
            builder.listen("127.0.0.1", static_cast<std::uint16_t>(my_port));
        session = builder.start(game);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "counter: %s\n", e.what());
        return 2;
    }

    // A scripted player: presses now and then, differently per slot.
    const lockroll::net::InputSource input = [&](std::uint32_t frame, std::span<std::uint8_t> in) {
        in[0] = static_cast<std::uint8_t>((frame / 7 + static_cast<std::uint32_t>(slot)) % 3 == 0 ? 1 : 0);
    };
    // The game's own loop, 100 frames a second against the match's 60 ticks: one update() a
    // frame (it never blocks), then the rest of the frame is the game's (here: sleeping).
    lockroll::net::RunOutcome outcome{};
    for (;;) {
        const lockroll::net::UpdateResult r = session->update(input);
        for (const auto& e : r.events)
            std::fprintf(stderr, "event %s peer %d frame %u %s\n", lockroll::rollback::event_name(e.kind), static_cast<int>(e.peer),
                         e.frame, e.detail.c_str());
        if (r.outcome) {
            outcome = *r.outcome;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }

    const auto checksum = session->session().confirmed_checksum(static_cast<std::uint32_t>(frames));
    std::printf("slot %d %s frame %ld checksum %016llx\n", slot, lockroll::net::outcome_name(outcome), frames,
                checksum ? static_cast<unsigned long long>(*checksum) : 0ull);
    return outcome == lockroll::net::RunOutcome::Completed && checksum ? 0 : 1;
}
