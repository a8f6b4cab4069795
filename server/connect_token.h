// Connect tokens, as netcode.io and yojimbo do them: what a matchmaker or backend grants one
// client (a room, a slot or a spectator place, a client id, an expiry, the room's parameters),
// sealed with a key the backend shares with the relay server. The client carries the token in
// its hello without being able to read or change it; a server started with the key admits a
// connection only as a valid, unexpired token says (server/relay_server.h). docs/relay.md says
// what a token protects against and what it does not; docs/wire-format.md "Connect tokens" has
// the bytes.
//
// Contract
//  - Sealing is libsodium's XChaCha20-Poly1305 (crypto_aead_xchacha20poly1305_ietf) with a fresh
//    random 24-byte nonce per token: no hand-written crypto. Layout: u16 version, the nonce, the
//    sealed grant (written field by field, little-endian), the 16-byte tag; the version and the
//    nonce are the associated data, so changing any byte of a token makes it fail to open.
//  - open_token trusts nothing: a wrong length, an unknown version, a tag that fails (a forged
//    or corrupted token, another key) or a grant out of range is a static description, never an
//    assert or an exception, and nothing is allocated.
//  - check_grant judges an opened grant against a hello and the server's wall clock (Unix
//    seconds): expired, or for another room, slot, role or room parameters, is a refusal. Player
//    and joiner grants are one: the server admits both alike.
//  - A token lists every slot its holder plays (slot, the lowest, and also_slots: several local
//    players on one connection); the hello must name exactly that set. One token, one
//    connection: the slots of a couch are granted together or not at all.
//  - The key and token files are hex text (64 digits for a key; whitespace around is ignored).
//    Reading one that is missing, malformed or of the wrong size throws std::invalid_argument
//    naming the file and what is wrong (the CLIs exit 2 on it before anything starts).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "rollback/relay_messages.h"

namespace lockroll::server {

// 2: the grant lists the further slots its connection plays (also_slots).
inline constexpr std::uint16_t kConnectTokenVersion = 2;
inline constexpr std::size_t kTokenNonceBytes = 24;
inline constexpr std::size_t kTokenTagBytes = 16;
inline constexpr std::size_t kConnectGrantBytes = 8 + 8 + 8 + 1 + 1 + 2 + 1 + 1 + 2 + 8 + 2;
inline constexpr std::size_t kConnectTokenBytes = 2 + kTokenNonceBytes + kConnectGrantBytes + kTokenTagBytes;
static_assert(kConnectTokenBytes <= rollback::kRelayMaxTokenBytes);

using TokenKey = std::array<std::uint8_t, 32>;
// The token's tag: unique per sealed token (random nonce), so it names the token for replay
// bookkeeping without keeping the token.
using TokenTag = std::array<std::uint8_t, kTokenTagBytes>;

struct ConnectGrant {
    std::uint64_t room_id = 0;
    std::uint64_t client_id = 0;          // who holds the slot: only this id takes it back
    std::uint64_t expires_unix_s = 0;     // accepted while the server's wall clock is before this
    rollback::RelayRole role = rollback::RelayRole::Player;
    std::uint8_t slot = 0;                // ignored for a spectator; the lowest slot granted
    std::uint16_t also_slots = 0;         // bit s: slot s too (all above `slot`; 0 for a spectator)
    // The room's parameters: a room is created with these, never with a hello's.
    std::uint8_t players = 2;
    std::uint8_t input_size = 3;
    std::uint16_t tick_rate = 60;
    std::uint64_t scene_checksum = 0;
    std::uint16_t absent_slots = 0;
};

bool operator==(const ConnectGrant& a, const ConnectGrant& b);

// A fresh random key. Throws std::runtime_error if libsodium cannot start.
TokenKey new_token_key();
// Throws std::runtime_error if libsodium cannot start, std::invalid_argument for a grant out of
// range (players 1..16, input size 1..64, tick rate 1..1000, slot below players, known role,
// also_slots above slot and below players, none for a spectator).
std::vector<std::uint8_t> seal_token(const ConnectGrant& grant, const TokenKey& key);
// nullptr on success (grant filled in, tag set), else why the token is refused.
const char* open_token(std::span<const std::uint8_t> token, const TokenKey& key, ConnectGrant& grant, TokenTag& tag);
// None when the grant admits this hello at unix_s; else TokenExpired or TokenMismatch.
rollback::RelayRefusal check_grant(const ConnectGrant& grant, const rollback::RelayHello& hello, std::uint64_t unix_s);

// Hex text files (see the contract).
TokenKey read_token_key(const std::string& path);
void write_token_key(const std::string& path, const TokenKey& key);
std::vector<std::uint8_t> read_token_file(const std::string& path);
void write_token_file(const std::string& path, std::span<const std::uint8_t> token);

}  // namespace lockroll::server
