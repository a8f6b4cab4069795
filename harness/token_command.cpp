#include "harness/token_command.h"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/cli_validators.h"
#include "harness/match/cli_error.h"
#include "harness/report/output_path.h"
#include "harness/peer_command.h"
#include "rollback/relay_session.h"
#include "rollback/world_simulation.h"
#include "server/connect_token.h"

namespace lockroll::harness {

namespace {

struct TokenOptions {
    std::string key;
    bool new_key = false;
    std::string room;
    std::vector<int> slots;  // --slot: one, or several (a couch on one connection: 0,1)
    int slot = -1;           // the lowest of them
    bool spectate = false;
    std::uint64_t client_id = 0;
    double expires_in = 3600;
    int players = 2;
    int tick_rate = 60;
    std::string scene = "paper";
    std::vector<int> absent;
    std::string out;
};

// The scene checksum a client of this scene sends in its hello: the relay session's own
// (RelaySessionConfig::scene_checksum 0 takes the simulation's initial-state checksum).
std::uint64_t scene_checksum(const TokenOptions& o) {
    const sim::SceneDesc scene = client_scene(o.scene, o.players, o.tick_rate);
    rollback::WorldSimulation sim(scene, o.players);
    rollback::RelaySessionConfig rc;
    rc.players = o.players;
    rc.role = o.spectate ? rollback::RelayRole::Spectator : rollback::RelayRole::Player;
    rc.local_slot = static_cast<rollback::PlayerId>(o.spectate ? 0 : o.slot);
    rc.input_size = rollback::kWorldInputSize;
    rc.tick_rate = o.tick_rate;
    const rollback::RelaySession session(rc, sim);
    return session.config().scene_checksum;
}

server::TokenKey key_or_usage(const std::string& path) {
    try {
        return server::read_token_key(path);
    } catch (const std::invalid_argument& e) {
        throw UsageError(std::string("--key: ") + e.what());
    }
}

int do_token(const TokenOptions& given) {
    TokenOptions o = given;
    if (!o.slots.empty()) o.slot = *std::min_element(o.slots.begin(), o.slots.end());
    if (o.key.empty()) throw UsageError("--key FILE is required");
    if (o.new_key) {
        if (std::filesystem::exists(o.key)) throw UsageError("--key " + o.key + ": exists; --new-key writes a new file only");
        check_output_file("--key", o.key);
        server::write_token_key(o.key, server::new_token_key());
        std::printf("key written to %s\n", o.key.c_str());
        return 0;
    }
    // Every flag checked before anything is computed or written.
    const server::TokenKey key = key_or_usage(o.key);
    if (o.room.empty()) throw UsageError("--room is required");
    if (o.out.empty()) throw UsageError("--out is required");
    if (o.players < 2 || o.players > rollback::kRelayMaxPlayers) throw UsageError("--players must be 2..16");
    if (!o.spectate && (o.slot < 0 || o.slot >= o.players)) throw UsageError("--slot must be 0..players-1 (or --spectate)");
    if (o.spectate && o.slot >= 0) throw UsageError("--slot and --spectate exclude each other (the server places a spectator)");
    std::uint16_t also = 0;  // the further slots of a couch's token
    if (!o.spectate) try {
            also = static_cast<std::uint16_t>(slot_mask(o.slots, o.players, "--slot") & ~(1u << o.slot));
        } catch (const std::invalid_argument& e) {
            throw UsageError(e.what());
        }
    if (o.tick_rate < 1 || o.tick_rate > 1000) throw UsageError("--tick-rate must be 1..1000");
    if (!(o.expires_in >= 1 && o.expires_in <= 10.0 * 365 * 86400)) throw UsageError("--expires-in must be 1 s..10 years");
    std::uint16_t absent = 0;
    for (int a : o.absent) {
        if (a < 0 || a >= o.players) throw UsageError("--absent must name slots 0..players-1");
        absent = static_cast<std::uint16_t>(absent | (1u << a));
    }
    check_output_file("--out", o.out);

    server::ConnectGrant g;
    g.room_id = match_hash(o.room);
    g.client_id = o.client_id;
    if (g.client_id == 0) {  // none given: a random one (a reconnect needs the same, so keep the token)
        std::random_device rd;
        g.client_id = (static_cast<std::uint64_t>(rd()) << 32 | rd()) | 1;
    }
    g.expires_unix_s = static_cast<std::uint64_t>(std::time(nullptr)) + static_cast<std::uint64_t>(o.expires_in);
    g.role = o.spectate ? rollback::RelayRole::Spectator : rollback::RelayRole::Player;
    g.slot = static_cast<std::uint8_t>(o.spectate ? 0 : o.slot);
    g.also_slots = also;
    g.players = static_cast<std::uint8_t>(o.players);
    g.input_size = static_cast<std::uint8_t>(rollback::kWorldInputSize);
    g.tick_rate = static_cast<std::uint16_t>(o.tick_rate);
    g.scene_checksum = scene_checksum(o);
    g.absent_slots = absent;
    server::write_token_file(o.out, server::seal_token(g, key));
    std::printf("token for room '%s' %s%s, client id %llu, expires at %llu (Unix s), written to %s\n", o.room.c_str(),
                o.spectate ? "spectator" : o.slots.size() > 1 ? "slots " : "slot ", o.spectate ? "" : slot_text(o.slots).c_str(),
                static_cast<unsigned long long>(g.client_id), static_cast<unsigned long long>(g.expires_unix_s), o.out.c_str());
    return 0;
}

}  // namespace

void add_token_command(CLI::App& app) {
    auto o = std::make_shared<TokenOptions>();
    CLI::App* cmd = app.add_subcommand(
        "token", "Issue a connect token for a relay server started with --key (or, with --new-key, write a fresh key)");
    cmd->add_option("--key", o->key, "FILE with the key shared with the server (64 hex digits)")->type_name("FILE");
    cmd->add_flag("--new-key", o->new_key, "Write a fresh random key to --key FILE and stop");
    cmd->add_option("--room", o->room, "Room the token admits to (the name lockroll client --room gives)");
    cmd->add_option("--slot", o->slots, "Slot the token admits to, 0..players-1; several (0,1) for one client playing them all")
        ->allow_extra_args(false)
        ->delimiter(',');
    cmd->add_flag("--spectate", o->spectate, "A spectator's token (no slot)");
    cmd->add_option("--client-id", o->client_id, "Who holds the slot: only this id's token takes it back (default: random)");
    cmd->add_option("--expires-in", o->expires_in, "Seconds the token admits for (also reconnects)")->capture_default_str();
    cmd->add_option("--players", o->players, "The room's players")->capture_default_str();
    cmd->add_option("--tick-rate", o->tick_rate, "The room's ticks per second")->capture_default_str();
    cmd->add_option("--scene", o->scene, "Scene file or shipped scene name the clients play (its checksum is sealed)")
        ->capture_default_str();
    cmd->add_option("--absent", o->absent, "Slot nobody plays at frame 0 (as every client says with --absent)");
    cmd->add_option("--out", o->out, "FILE to write the token to (hex text)")->type_name("FILE");
    cmd->callback([o] { do_token(*o); });
}

}  // namespace lockroll::harness
