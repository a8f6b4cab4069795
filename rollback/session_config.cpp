#include "rollback/session.h"

#include <stdexcept>
#include <string>

#include "rollback/protocol.h"

namespace lockroll::rollback {

namespace {
[[noreturn]] void config_error(const std::string& what) { throw std::invalid_argument("session config: " + what); }
// A macro, so that a check's message (a std::string, often with std::to_string in it) is built
// only when the check fails: validate() runs in every construction, and building its forty-odd
// messages eagerly was a quarter of the allocations of constructing a session. #undef after
// validate().
#define LOCKROLL_REQUIRE(ok, what)              \
    do {                               \
        if (!(ok)) config_error(what); \
    } while (false)
}  // namespace

void validate(const SessionConfig& c) {
    LOCKROLL_REQUIRE(c.players >= 1 && c.players <= kMaxPlayers, "players must be 1.." + std::to_string(kMaxPlayers));
    LOCKROLL_REQUIRE(c.max_spectators >= 0 && c.max_spectators <= 255 - c.players,  // no overflow for any int
            "max_spectators must be 0.." + std::to_string(255 - c.players));
    if (c.role == Role::Spectator)
        LOCKROLL_REQUIRE(c.local_player >= static_cast<PlayerId>(c.players) &&
                    c.local_player < static_cast<PlayerId>(c.players + c.max_spectators),
                "a spectator's local id must be players .. players + max_spectators - 1");
    else
        LOCKROLL_REQUIRE(c.local_player < static_cast<PlayerId>(c.players), "local_player must be a player slot");
    LOCKROLL_REQUIRE((c.absent_slots >> c.local_player & 1) == 0 || c.role != Role::Player,
            "the local slot cannot be absent at frame 0");
    LOCKROLL_REQUIRE(c.role == Role::Player || c.handshake, "joiners and spectators need the handshake");
    LOCKROLL_REQUIRE(c.input_size >= 1 && c.input_size <= kMaxInputSize,
            "input_size must be 1.." + std::to_string(kMaxInputSize));
    LOCKROLL_REQUIRE(c.tick_rate >= 1 && c.tick_rate <= 10000, "tick_rate must be 1..10000");
    LOCKROLL_REQUIRE(c.prediction_window >= 0 && c.prediction_window <= 120, "prediction_window must be 0..120");
    LOCKROLL_REQUIRE(c.input_capacity >= 64 && (c.input_capacity & (c.input_capacity - 1)) == 0,
            "input_capacity must be a power of two >= 64");
    const int max_delay = static_cast<int>(c.input_capacity / 4);
    LOCKROLL_REQUIRE(c.input_delay >= 0 && c.input_delay <= max_delay, "input_delay must be 0.." + std::to_string(max_delay));
    LOCKROLL_REQUIRE(static_cast<std::uint32_t>(c.prediction_window) < c.input_capacity / 4,
            "prediction_window must be below input_capacity / 4");
    LOCKROLL_REQUIRE(c.checksum_interval >= 1 && c.checksum_interval <= 65535, "checksum_interval must be 1..65535");
    LOCKROLL_REQUIRE(c.checksum_repeats >= 1, "checksum_repeats must be >= 1");
    LOCKROLL_REQUIRE(c.evidence_frames >= 1 && c.evidence_frames <= 100000, "evidence_frames must be 1..100000");
    LOCKROLL_REQUIRE(c.max_bad_packets >= 1, "max_bad_packets must be >= 1");
    LOCKROLL_REQUIRE(c.time_sync_window >= 1 && c.time_sync_window <= 100000, "time_sync_window must be >= 1");
    LOCKROLL_REQUIRE(c.time_sync_min_frames >= 1, "time_sync_min_frames must be >= 1");
    LOCKROLL_REQUIRE(c.time_sync_every >= 1, "time_sync_every must be >= 1");
    LOCKROLL_REQUIRE(c.max_replies_per_poll >= 1, "max_replies_per_poll must be >= 1");
    LOCKROLL_REQUIRE(c.sync_roundtrips >= 1 && c.sync_roundtrips <= 100, "sync_roundtrips must be 1..100");
    LOCKROLL_REQUIRE(c.disconnect_us == 0 || c.interrupt_us < c.disconnect_us, "interrupt_us must be below disconnect_us");
    LOCKROLL_REQUIRE(c.transfer_window >= 1 && c.transfer_window <= 1024, "transfer_window must be 1..1024");
    LOCKROLL_REQUIRE(c.max_recoveries >= 0, "max_recoveries must be >= 0");
    LOCKROLL_REQUIRE(c.relay_lag >= 0, "relay_lag must be >= 0");
    LOCKROLL_REQUIRE(c.two_player_rule == TwoPlayerRule::PlayOnAlone || c.two_player_rule == TwoPlayerRule::NoDrop,
            "two_player_rule must be PlayOnAlone or NoDrop");
    if (!c.slot_hosts.empty()) {
        LOCKROLL_REQUIRE(c.slot_hosts.size() == static_cast<std::size_t>(c.players), "slot_hosts must have one entry per slot");
        bool guests = false;
        for (std::size_t s = 0; s < c.slot_hosts.size(); ++s) {
            const PlayerId h = c.slot_hosts[s];
            LOCKROLL_REQUIRE(h <= s && c.slot_hosts[h] == h,
                    "slot_hosts[" + std::to_string(s) + "] must be a slot <= " + std::to_string(s) + " that hosts itself");
            LOCKROLL_REQUIRE((c.absent_slots >> s & 1) == (c.absent_slots >> h & 1),
                    "slot " + std::to_string(s) + " must be absent exactly when its host is");
            if (h != s && h == c.local_player) guests = true;
        }
        if (c.role != Role::Spectator)
            LOCKROLL_REQUIRE(c.slot_hosts[c.local_player] == c.local_player, "local_player must be the lowest slot of its process");
        LOCKROLL_REQUIRE(!guests || c.role == Role::Player, "a joiner cannot host other slots yet");
    }
}
#undef LOCKROLL_REQUIRE

}  // namespace lockroll::rollback
