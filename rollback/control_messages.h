// Control messages: the handshake (hello / welcome, which also measure the round trip before
// frame 0) and the snapshot transfer a late joiner, a rejoining player, a spectator or a peer
// recovering from a desync pulls from a running peer. Byte layout: docs/wire-format.md.
//
// Contract (as protocol.h): every field written on its own, little-endian; decoding checks
// every length against the bytes present and fixed limits before allocating, rejects trailing
// bytes, and reports failure as a static string, never an assert or exception.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rollback/protocol.h"
#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

// Role (what a peer asks to be when it says hello): rollback/session_types.h.
inline constexpr std::uint8_t kLastRole = 2;

// Why a hello was not welcomed. Retry is not a refusal: the peer is not ready yet (a rejoining
// slot's old connection is still being dropped); the joiner keeps saying hello.
enum class Refusal : std::uint8_t {
    None = 0,
    Version = 1,       // protocol versions differ
    MatchId = 2,       // another match
    Scene = 3,         // the initial states' checksums differ (another scene or build)
    SlotTaken = 4,     // the slot is running and the hello is not a rejoin
    Full = 5,          // no spectator place left
    Retry = 6,         // not yet: say hello again
    Disconnected = 7,  // you were dropped from this match (sent to a peer that keeps talking)
    BadRole = 8,       // e.g. a spectator id claiming a player's role
};
inline constexpr std::uint8_t kLastRefusal = 8;
const char* refusal_name(Refusal r);

struct HelloMessage {
    std::uint16_t version = kProtocolVersion;
    std::uint64_t match_id = 0;
    std::uint64_t scene_checksum = 0;
    Role role = Role::Player;
    std::uint64_t stamp_us = 0;  // the sender's clock; echoed in the welcome (round trip)
    // Which process this is: the same for all its hellos, different for a restarted one, so a
    // repeated hello is never mistaken for a restart (and a restart is noticed at once).
    std::uint64_t incarnation = 0;
};

struct WelcomeMessage {
    Refusal refusal = Refusal::None;
    // The answering side's own values, so a refused peer can say what differed.
    std::uint16_t version = kProtocolVersion;
    std::uint64_t match_id = 0;
    std::uint64_t scene_checksum = 0;
    std::uint64_t echo_us = 0;  // the hello's stamp
    bool running = false;       // the answering side has started frame 0
    // The answering side's epoch of the hello sender's slot: a "disconnected" refusal counts
    // only when it is newer than the sender's own view (a rejoined process may hear from a peer
    // that has not learned of its rejoin yet).
    std::uint8_t slot_epoch = 0;
};

// Why a snapshot is wanted; the provider decides what to hand over with it.
enum class TransferReason : std::uint8_t { Join = 0, Spectate = 1, Recover = 2 };
inline constexpr std::uint8_t kLastTransferReason = 2;

// Pull-based transfer: the receiver asks for an offer, then for chunks by index, re-asking what
// does not arrive, so it works over any unreliable transport (and faster over a reliable one).
struct SnapshotRequestMessage {
    TransferReason reason = TransferReason::Join;
    std::uint32_t transfer_id = 0;  // 0: please offer; else the offer being pulled
    std::uint32_t chunk = 0;        // with transfer_id != 0: the chunk wanted
};

struct SnapshotOfferMessage {
    TransferReason reason = TransferReason::Join;
    std::uint32_t transfer_id = 0;   // non-zero, chosen by the provider
    std::uint32_t frame = 0;         // the confirmed frame the snapshot holds
    std::uint32_t size = 0;          // bytes of the whole transfer blob
    std::uint64_t hash = 0;          // XXH3-64 of the blob
    std::uint32_t handoff_frame = 0; // Join: the first frame whose input the joiner sends
    std::vector<SlotEntry> slots;    // the provider's slot table (counts unused)
};

inline constexpr std::size_t kSnapshotChunkBytes = 1024;

struct SnapshotChunkMessage {
    std::uint32_t transfer_id = 0;
    std::uint32_t chunk = 0;
    std::vector<std::uint8_t> bytes;  // 1..kSnapshotChunkBytes
};

void encode(const HelloMessage& m, std::vector<std::uint8_t>& out);
void encode(const WelcomeMessage& m, std::vector<std::uint8_t>& out);
void encode(const SnapshotRequestMessage& m, std::vector<std::uint8_t>& out);
void encode(const SnapshotOfferMessage& m, std::vector<std::uint8_t>& out);
void encode(const SnapshotChunkMessage& m, std::vector<std::uint8_t>& out);

const char* decode(std::span<const std::uint8_t> datagram, HelloMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, WelcomeMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, SnapshotRequestMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, SnapshotOfferMessage& m);
const char* decode(std::span<const std::uint8_t> datagram, SnapshotChunkMessage& m);

}  // namespace lockroll::rollback
