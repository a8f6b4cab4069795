// Players are value ids: the player slot 0..players-1. In a peer-to-peer session each client
// has one local player, so a player id is also the peer id of that player's client; the
// transport maps ids to addresses, rollback/ never sees one.
#pragma once

#include <cstdint>

namespace lockroll::rollback {

using PlayerId = std::uint32_t;

// Upper bound on players per session (inputs of all players travel in one step() call, and
// per-frame prediction masks are one 64-bit word).
inline constexpr int kMaxPlayers = 64;

}  // namespace lockroll::rollback
