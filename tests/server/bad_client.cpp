// A misbehaving relay client for the process tests (tests/server/relay_processes_test.sh): it
// joins a room properly, then breaks the rules one way, and reports whether the server closed
// its connection. Exit 0: disconnected by the server within --seconds; 1: still connected.
//   spoof    says hello again, for another slot
//   garbage  sends random bytes
//   flood    sends valid input messages at 5,000 per second
//   future   sends inputs for frame 10,000 and beyond
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "rollback/relay_messages.h"
#include "harness/match/match.h"
#include "harness/match/scene_loader.h"
#include "rollback/relay_session.h"
#include "rollback/world_simulation.h"
#include "transport/enet_transport.h"

using namespace lockroll;

namespace {
std::uint64_t now_us() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
}
std::uint64_t room_hash(const std::string& id) {  // as lockroll client's --room
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : id) h = (h ^ c) * 0x100000001b3ull;
    return h;
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"relay bad client (tests)"};
    std::string connect, room, behavior;
    int slot = 0, players = 2, claim = 0;
    double seconds = 10;
    std::string scene_name = "paper";
    app.add_option("--connect", connect)->required();
    app.add_option("--room", room)->required();
    app.add_option("--slot", slot)->required();
    app.add_option("--players", players);
    app.add_option("--scene", scene_name, "the room's scene (its checksum goes in the hello)");
    app.add_option("--claim", claim, "spoof: the slot to claim");
    app.add_option("--behavior", behavior)->check(CLI::IsMember({"spoof", "garbage", "flood", "future"}))->required();
    app.add_option("--seconds", seconds);
    CLI11_PARSE(app, argc, argv);
    const auto colon = connect.rfind(':');
    const std::string host = connect.substr(0, colon);
    const auto port = static_cast<std::uint16_t>(std::stoi(connect.substr(colon + 1)));

    transport::EnetTransport enet({.local_id = 900, .bind_host = "127.0.0.1", .port = 0, .max_peers = 2});
    const transport::PeerId server = rollback::kRelayServerPeer;
    enet.connect(server, host, port);
    // The room's scene checksum, as an honest client computes it: the initial state's.
    rollback::WorldSimulation sim(harness::with_players(harness::load_scene(scene_name), players), players);
    std::vector<std::uint8_t> state(sim.state_size());
    sim.save(state);
    const std::uint64_t scene = sim.checksum(state);
    rollback::RelayHello h;
    h.room_id = room_hash(room);
    h.scene_checksum = scene;
    h.players = static_cast<std::uint8_t>(players);
    h.input_size = 3;
    h.tick_rate = 60;
    h.slot = static_cast<std::uint8_t>(slot);
    std::vector<std::uint8_t> hello;
    rollback::encode(h, hello);
    std::mt19937 rng(static_cast<unsigned>(slot) * 7919u + 1u);
    bool connected = false, welcomed = false;
    std::uint32_t frame = 0;
    const std::uint64_t end = now_us() + static_cast<std::uint64_t>(seconds * 1e6);
    std::uint64_t last = 0;
    while (now_us() < end) {
        const std::uint64_t now = now_us();
        enet.poll(now);
        for (transport::TransportEvent e; enet.next_event(e);) {
            if (e.type == transport::TransportEvent::Type::Connected) {
                connected = true;
                enet.send_reliable(server, hello, now);
            }
            if (e.type == transport::TransportEvent::Type::Disconnected && connected) {
                std::printf("disconnected by the server after %s (%s)\n", behavior.c_str(), e.reason.c_str());
                return 0;
            }
        }
        for (transport::Datagram d; enet.receive(d, now);)
            if (rollback::peek_relay_kind(d.bytes) == rollback::RelayKind::Welcome) welcomed = true;
        const int per_tick = behavior == "flood" ? 80 : 1;
        if (welcomed && now - last >= 16000) {
            last = now;
            for (int i = 0; i < per_tick; ++i) {
                std::vector<std::uint8_t> bytes;
                if (behavior == "spoof") {
                    rollback::RelayHello other = h;
                    other.slot = static_cast<std::uint8_t>(claim);
                    rollback::encode(other, bytes);
                } else if (behavior == "garbage") {
                    bytes.resize(1 + rng() % 200);
                    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
                    bytes[0] = static_cast<std::uint8_t>(34 + rng() % 3);  // look like relay kinds
                } else {
                    rollback::RelayInput m;
                    m.confirmed_ack = 0;
                    m.first_frame = behavior == "future" ? 10000 + frame : frame;
                    m.frame_count = 1;
                    m.slots = static_cast<std::uint16_t>(1u << slot);
                    m.inputs.assign(3, static_cast<std::uint8_t>(rng()));
                    rollback::encode(m, 3, bytes);
                }
                enet.send(server, bytes, now);
            }
            ++frame;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    std::printf("still connected after %.0f s of %s\n", seconds, behavior.c_str());
    return 1;
}
