// A game outside lockroll, built against the installed package: it uses every installed library
// through the surface headers only (cmake/PublicHeaders.cmake), spelled as a consumer writes them
// (<lockroll/...>).
//  - lockroll::sim: builds a small World in code (a room, a player capsule, a spawner of balls)
//    and steps it with a scripted input; the checksum is the WorldSimulation's.
//  - lockroll::rollback: two Sessions run a toy Simulation of the consumer's own (a counter per
//    player) in virtual time and must agree on every confirmed checksum; their datagrams travel
//    over the consumer's own delay line, losing every 13th.
//  - lockroll::transport: an EnetTransport binds 127.0.0.1 (so ENet, a private dependency, links).
//  - lockroll::net: a SessionBuilder validates a 2-player mesh config (a compiled function).
// tests/install runs this built against the installed package (CMake and pkg-config) and built
// in-tree; the outputs must be identical.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <lockroll/net/session_builder.h>
#include <lockroll/rollback/session.h>
#include <lockroll/rollback/simulation.h>
#include <lockroll/rollback/world_simulation.h>
#include <lockroll/sim/world.h>
#include <lockroll/transport/enet_transport.h>

namespace {

std::string world_line() {
    using namespace lockroll::sim;
    SceneDesc scene;
    scene.name = "consumer";
    const Vec3 lo{Fixed::from_int(-5), Fixed::zero(), Fixed::from_int(-5)};
    const Vec3 hi{Fixed::from_int(5), Fixed::from_int(4), Fixed::from_int(5)};
    add_room(scene, lo, hi, Fixed::one());

    BodyDesc player;
    player.shape = Shape::Capsule;
    player.position = {Fixed::zero(), Fixed::one(), Fixed::zero()};
    player.radius = Fixed::ratio(3, 10);
    player.half_height = Fixed::ratio(1, 2);
    player.mass = Fixed::from_int(70);
    player.player = 0;
    scene.bodies.push_back(player);

    SpawnerDesc balls;
    balls.count = 40;
    balls.radius = Fixed::ratio(1, 5);
    balls.region_min = {Fixed::from_int(-4), Fixed::one(), Fixed::from_int(-4)};
    balls.region_max = {Fixed::from_int(4), Fixed::from_int(3), Fixed::from_int(4)};
    balls.max_speed = Fixed::from_int(3);
    balls.seed = 42;
    expand_spawner(scene, balls);

    if (const std::string error = validate(scene); !error.empty()) return "invalid scene: " + error;
    lockroll::rollback::WorldSimulation game(scene, 1);
    PlayerInput input;
    for (std::uint32_t f = 0; f < 300; ++f) {
        input.forward = static_cast<std::int8_t>(f % 120 < 60 ? 127 : -127);
        input.right = static_cast<std::int8_t>(f % 90 < 45 ? 64 : -64);
        game.step(lockroll::rollback::encode_input(input));
    }
    const World& world = game.world();
    std::vector<std::uint8_t> state(game.state_size());
    const auto saved = game.save_to(state);
    char buf[160];
    std::snprintf(buf, sizeof buf, "world %zu bodies, frame %" PRIu32 ", overflows %" PRIu64 ", checksum %016" PRIx64,
                  world.body_count(), world.frame(), world.overflow_count(), game.checksum(saved));
    return buf;
}

// The consumer's own game: one signed counter per player, moved by a one-byte input.
class Counters : public lockroll::rollback::Simulation {
public:
    using Simulation::step;  // the status overload forwards here
    void step(std::span<const std::uint8_t> inputs) override {
        for (std::size_t p = 0; p < 2; ++p) value_[p] += static_cast<std::int8_t>(inputs[p]);
    }
    std::size_t state_size() const override { return 16; }
    void save(std::span<std::uint8_t> out) const override {
        for (std::size_t i = 0; i < 16; ++i)
            out[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(value_[i / 8]) >> (8 * (i % 8)));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() != 16) return "counters state must be 16 bytes";
        for (std::size_t p = 0; p < 2; ++p) {
            std::uint64_t v = 0;
            for (std::size_t i = 0; i < 8; ++i) v |= std::uint64_t{in[p * 8 + i]} << (8 * i);
            value_[p] = static_cast<std::int64_t>(v);
        }
        return {};
    }

private:
    std::int64_t value_[2] = {0, 0};
};

std::string session_line() {
    using namespace lockroll;
    // The consumer's own network: every datagram arrives 40 ms after it was sent, but every 13th
    // is lost (so the sessions must resend).
    struct InFlight {
        std::uint64_t due;
        rollback::PlayerId from;
        std::vector<std::uint8_t> bytes;
    };
    std::vector<InFlight> wire[2];
    std::uint64_t sent = 0;

    Counters games[2];
    std::unique_ptr<rollback::Session> sessions[2];
    for (rollback::PlayerId p = 0; p < 2; ++p) {
        rollback::SessionConfig cfg;
        cfg.players = 2;
        cfg.local_player = p;
        cfg.input_size = 1;
        sessions[p] = std::make_unique<rollback::Session>(cfg, games[p]);
    }
    std::vector<rollback::Datagram> out;
    for (std::uint64_t tick = 0; tick < 600; ++tick) {
        const std::uint64_t now = tick * 16667;
        for (rollback::PlayerId p = 0; p < 2; ++p) {
            auto& inbox = wire[p];
            for (const auto& d : inbox)
                if (d.due <= now) sessions[p]->receive(d.from, d.bytes, now);
            std::erase_if(inbox, [now](const InFlight& d) { return d.due <= now; });
            const std::uint8_t input = static_cast<std::uint8_t>((tick / 7 + p) % 3 == 0 ? 3 : -1);
            sessions[p]->advance(std::span(&input, 1), now);
            out.clear();
            sessions[p]->poll(now, out);
            for (const auto& d : out)
                if (++sent % 13 != 0) wire[d.peer].push_back({now + 40000, p, d.bytes});
        }
    }
    const std::uint32_t confirmed = std::min(sessions[0]->confirmed_frame(), sessions[1]->confirmed_frame());
    const auto a = sessions[0]->confirmed_checksum(confirmed), b = sessions[1]->confirmed_checksum(confirmed);
    char buf[160];
    std::snprintf(buf, sizeof buf, "session confirmed %" PRIu32 " %s, checksum %016" PRIx64, confirmed,
                  a && b && *a == *b ? "agree" : "DISAGREE", a.value_or(0));
    return buf;
}

std::string enet_line() {
    lockroll::transport::EnetConfig cfg;  // 127.0.0.1, an ephemeral port
    lockroll::transport::EnetTransport enet(cfg);
    return enet.port() != 0 ? "enet bound" : "enet NOT bound";
}

// The real-time layer's builder: validates a mesh without binding a port (compiled, so it links).
std::string net_line() {
    lockroll::net::SessionBuilder builder;
    builder.players(2).input_size(1).local_player(0).remote_player(1, "127.0.0.1", 4000).tick_rate(30);
    const auto cfg = builder.session_config();
    return cfg.players == 2 && cfg.local_player == 0 && cfg.tick_rate == 30 ? "net builds"
                                                                                              : "net FAILED";
}

}  // namespace

int main() {
    const std::string world = world_line(), session = session_line(), enet = enet_line(), net = net_line();
    std::printf("lockroll consumer: %s; %s; %s; %s\n", world.c_str(), session.c_str(), enet.c_str(), net.c_str());
    const bool ok = world.find("frame 300,") != std::string::npos && session.find(" agree") != std::string::npos &&
                    enet == "enet bound" && net == "net builds";
    return ok ? 0 : 1;
}
