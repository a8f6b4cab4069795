// A misbehaving relay client for the process tests (tests/server/relay_processes_test.sh): it
// joins a room properly, then breaks the rules one way, and reports whether the server closed
// its connection. Exit 0: disconnected by the server within --seconds; 1: still connected.
//   spoof    says hello again, for another slot
//   garbage  sends random bytes
//   flood    sends valid input messages at 5,000 per second
//   future   sends inputs for frame 10,000 and beyond
//   steal    says hello for --slot of a room (--room-id: any room, e.g. relay_bench's) whose
//            holder is live, and reports the answer: exit 0 refused, 1 admitted or no answer
//   refused  cycles connections (--parallel at once): each says a hello of a protocol version
//            the server does not speak, is refused and kicked (two warn lines in the server's
//            log), and connects again; for --seconds. Exit 0 if the server refused at least
//            one (it prints how many): a log flood from one address (tests/server/
//            relay_log_pressure_test.sh)
//   liar     plays the match with real inputs (a full RelaySession through the builder) but
//            reports a wrong checksum for every frame and never hears the server's desync
//            verdicts or its kick, so it goes on disagreeing round after round and comes back
//            after a kick (issue 20's persistent liar)
#include <chrono>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "net/session_builder.h"
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

// The liar's transport: ENet underneath; every Input message it sends has its checksums
// altered, and every desync and kicked Notice from the server is swallowed (so the liar's
// session never reloads or fails: it keeps lying, and when its connection is closed its
// transport reconnects and says hello again). Everything else passes through unchanged.
class LyingTransport final : public transport::Transport {
public:
    LyingTransport(transport::EnetTransport& inner, std::size_t input_size) : inner_(inner), input_size_(input_size) {}
    transport::PeerId local_id() const override { return inner_.local_id(); }
    bool send(transport::PeerId to, std::span<const std::uint8_t> bytes, transport::Micros now) override {
        return inner_.send(to, lie(bytes), now);
    }
    bool send_reliable(transport::PeerId to, std::span<const std::uint8_t> bytes, transport::Micros now) override {
        return inner_.send_reliable(to, lie(bytes), now);
    }
    bool receive(transport::Datagram& out, transport::Micros now) override {
        while (inner_.receive(out, now)) {
            rollback::RelayNotice n;
            if (rollback::peek_relay_kind(out.bytes) == rollback::RelayKind::Notice && !rollback::decode(out.bytes, n) &&
                (n.kind == rollback::RelayNoticeKind::Desync || n.kind == rollback::RelayNoticeKind::Kicked)) {
                ++verdicts_ignored;
                continue;
            }
            return true;
        }
        return false;
    }
    const transport::TransportCounters& counters() const override { return inner_.counters(); }
    bool next_event(transport::TransportEvent& out) override { return inner_.next_event(out); }
    bool connect(transport::PeerId remote, const std::string& host, std::uint16_t port, std::string* error) override {
        return inner_.connect(remote, host, port, error);
    }
    bool is_connected(transport::PeerId remote) const override { return inner_.is_connected(remote); }
    void poll(transport::Micros now) override { inner_.poll(now); }

    std::uint64_t checksums_altered = 0;
    std::uint64_t verdicts_ignored = 0;

private:
    std::span<const std::uint8_t> lie(std::span<const std::uint8_t> bytes) {
        rollback::RelayInput m;
        if (rollback::peek_relay_kind(bytes) != rollback::RelayKind::Input || rollback::decode(bytes, input_size_, m) ||
            m.checksum_count == 0)
            return bytes;
        for (std::uint8_t i = 0; i < m.checksum_count; ++i) m.checksums[i] ^= 0x5a5a5a5a5a5a5a5aull;
        checksums_altered += m.checksum_count;
        out_.clear();
        rollback::encode(m, input_size_, out_);
        return out_;
    }
    transport::EnetTransport& inner_;
    std::size_t input_size_;
    std::vector<std::uint8_t> out_;
};

// --behavior liar: a whole match through the builder over LyingTransport. Exit 0 when the
// session ended within --seconds (the server kicked it and refused it back), 1 otherwise.
int run_liar(const std::string& host, std::uint16_t port, const std::string& room, int slot, int players,
             const std::string& scene_name, double seconds) {
    transport::EnetTransport enet({.local_id = static_cast<transport::PeerId>(slot), .bind_host = "127.0.0.1", .port = 0,
                                   .max_peers = 2});
    LyingTransport liar(enet, 3);
    rollback::WorldSimulation sim(harness::with_players(harness::load_scene(scene_name), players), players);
    auto session = net::SessionBuilder()
                       .players(players)
                       .input_size(3)
                       .local_player(static_cast<rollback::PlayerId>(slot))
                       .server(host, port)
                       .match_id(room_hash(room))
                       .transport(liar)
                       .start(sim);
    const net::InputSource input = [](std::uint32_t frame, std::span<std::uint8_t> out) {
        // Real, varying inputs: the liar plays; only its checksums are false.
        for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>((frame / 20 + i) % 3);
    };
    const auto end = std::chrono::steady_clock::now() + std::chrono::microseconds(static_cast<std::int64_t>(seconds * 1e6));
    while (std::chrono::steady_clock::now() < end) {
        const net::UpdateResult r = session->update(input);
        for (const rollback::SessionEvent& e : r.events)
            if (e.kind == rollback::SessionEvent::Kind::Failed || e.kind == rollback::SessionEvent::Kind::ServerLost ||
                e.kind == rollback::SessionEvent::Kind::Kicked) {
                std::printf("liar: session ended (%s: %s) after %llu altered checksums, %llu verdicts ignored\n",
                            rollback::event_name(e.kind), e.detail.c_str(),
                            static_cast<unsigned long long>(liar.checksums_altered),
                            static_cast<unsigned long long>(liar.verdicts_ignored));
                return liar.checksums_altered > 0 ? 0 : 1;
            }
        if (r.outcome) {
            std::printf("liar: run over (%s) after %llu altered checksums, %llu verdicts ignored\n", net::outcome_name(*r.outcome),
                        static_cast<unsigned long long>(liar.checksums_altered),
                        static_cast<unsigned long long>(liar.verdicts_ignored));
            return *r.outcome == net::RunOutcome::Completed ? 1 : 0;
        }
        session->wait();
    }
    std::printf("liar: still playing after %.0f s (%llu altered checksums, %llu verdicts ignored)\n", seconds,
                static_cast<unsigned long long>(liar.checksums_altered), static_cast<unsigned long long>(liar.verdicts_ignored));
    return 1;
}
// --behavior refused: `parallel` connections, each cycling connect / refused hello / kick for
// `seconds`. Every refusal costs the server two log lines (refused, kicked), so this is a log
// flood that ENet's and the server's per-connection limits do not stop: each connection is new.
int run_refused(const std::string& host, std::uint16_t port, std::uint64_t room_id, int parallel, double seconds) {
    struct Cycler {
        std::unique_ptr<transport::EnetTransport> enet;
        bool connecting = false;
    };
    std::vector<Cycler> cyclers(static_cast<std::size_t>(parallel));
    for (Cycler& c : cyclers)
        c.enet = std::make_unique<transport::EnetTransport>(
            transport::EnetConfig{.local_id = 900, .bind_host = "127.0.0.1", .port = 0, .max_peers = 2});
    const transport::PeerId server = rollback::kRelayServerPeer;
    rollback::RelayHello h;
    h.version = rollback::kRelayProtocolVersion + 1;  // refused: version
    h.room_id = room_id;
    h.players = 2;
    h.input_size = 3;
    h.tick_rate = 60;
    std::vector<std::uint8_t> hello;
    rollback::encode(h, hello);
    std::uint64_t refusals = 0, cycles = 0;
    const std::uint64_t end = now_us() + static_cast<std::uint64_t>(seconds * 1e6);
    while (now_us() < end) {
        const std::uint64_t now = now_us();
        for (Cycler& c : cyclers) {
            if (!c.connecting) c.connecting = c.enet->connect(server, host, port);
            c.enet->poll(now);
            for (transport::TransportEvent e; c.enet->next_event(e);) {
                if (e.type == transport::TransportEvent::Type::Connected) c.enet->send_reliable(server, hello, now);
                if (e.type == transport::TransportEvent::Type::Disconnected) {
                    c.connecting = false;  // kicked (or timed out): connect again
                    ++cycles;
                }
            }
            for (transport::Datagram d; c.enet->receive(d, now);) {
                rollback::RelayWelcome w;
                if (rollback::peek_relay_kind(d.bytes) == rollback::RelayKind::Welcome && !rollback::decode(d.bytes, w) &&
                    w.refusal != rollback::RelayRefusal::None)
                    ++refusals;
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    std::printf("refused: %llu hellos refused, %llu connections closed in %.0f s\n", static_cast<unsigned long long>(refusals),
                static_cast<unsigned long long>(cycles), seconds);
    return refusals > 0 ? 0 : 1;
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"relay bad client (tests)"};
    std::string connect, room, behavior, room_id_text, scene_checksum_text;
    int slot = 0, players = 2, claim = 0, parallel = 8;
    double seconds = 10;
    std::string scene_name = "paper";
    app.add_option("--connect", connect)->required();
    auto* room_opt = app.add_option("--room", room);
    app.add_option("--room-id", room_id_text, "the room's 64-bit id in hex (instead of --room's name)")->excludes(room_opt);
    app.add_option("--scene-checksum", scene_checksum_text, "steal: the room's scene checksum in hex (default: --scene's)");
    app.add_option("--slot", slot)->required();
    app.add_option("--players", players);
    app.add_option("--scene", scene_name, "the room's scene (its checksum goes in the hello)");
    app.add_option("--claim", claim, "spoof: the slot to claim");
    app.add_option("--parallel", parallel, "refused: connections cycling at once")->check(CLI::Range(1, 32));
    app.add_option("--behavior", behavior)->check(CLI::IsMember({"spoof", "garbage", "flood", "future", "liar", "steal", "refused"}))->required();
    app.add_option("--seconds", seconds);
    CLI11_PARSE(app, argc, argv);
    if (room.empty() == room_id_text.empty()) {
        std::fprintf(stderr, "bad_client: give --room or --room-id\n");
        return 2;
    }
    const auto colon = connect.rfind(':');
    const std::string host = connect.substr(0, colon);
    const auto port = static_cast<std::uint16_t>(std::stoi(connect.substr(colon + 1)));
    if (behavior == "liar") return run_liar(host, port, room, slot, players, scene_name, seconds);
    if (behavior == "refused")
        return run_refused(host, port, room_id_text.empty() ? room_hash(room) : std::stoull(room_id_text, nullptr, 16), parallel,
                           seconds);

    transport::EnetTransport enet({.local_id = 900, .bind_host = "127.0.0.1", .port = 0, .max_peers = 2});
    const transport::PeerId server = rollback::kRelayServerPeer;
    enet.connect(server, host, port);
    // The room's scene checksum, as an honest client computes it: the initial state's.
    rollback::WorldSimulation sim(harness::with_players(harness::load_scene(scene_name), players), players);
    std::vector<std::uint8_t> state(sim.state_size());
    sim.save(state);
    const std::uint64_t scene = sim.checksum(state);
    rollback::RelayHello h;
    h.room_id = room_id_text.empty() ? room_hash(room) : std::stoull(room_id_text, nullptr, 16);
    h.scene_checksum = scene_checksum_text.empty() ? scene : std::stoull(scene_checksum_text, nullptr, 16);
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
            if (e.type == transport::TransportEvent::Type::Disconnected && connected && behavior == "steal") {
                // The server refuses, then closes: the close can be polled before the refusal
                // is read. Either way the slot was not taken.
                std::printf("steal: refused (the server closed the connection: %s)\n", e.reason.c_str());
                return 0;
            }
            if (e.type == transport::TransportEvent::Type::Disconnected && connected) {
                std::printf("disconnected by the server after %s (%s)\n", behavior.c_str(), e.reason.c_str());
                return 0;
            }
        }
        for (transport::Datagram d; enet.receive(d, now);) {
            if (rollback::peek_relay_kind(d.bytes) != rollback::RelayKind::Welcome) continue;
            rollback::RelayWelcome w;
            if (rollback::decode(d.bytes, w)) continue;
            if (behavior == "steal") {
                if (w.refusal == rollback::RelayRefusal::None) {
                    std::printf("steal: admitted to slot %d (the live holder lost it)\n", static_cast<int>(w.slot));
                    return 1;
                }
                std::printf("steal: refused: %s\n", rollback::relay_refusal_name(w.refusal));
                return 0;
            }
            welcomed = welcomed || w.refusal == rollback::RelayRefusal::None;
        }
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
