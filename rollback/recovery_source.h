// Whom a desynced P2P session reloads from (issue 21's desync recovery): the slots are grouped by
// their confirmed checksum of the first frame that differs; the biggest group is right, and a
// tie between groups (always so with two players) keeps the group of the lowest slot (or the
// highest, DesyncKeep::HighestSlot). Only the low 32 bits of a checksum are compared.
//
// Contract: nullopt when `me` is in the group kept (the others reload); else the lowest slot of
// that group, whose state `me` reloads. Pure: no session, no time. The rule itself is
// rollback/arbitration.h's, the one the relay server's rooms decide with.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <utility>

#include "rollback/session.h"

namespace lockroll::rollback {

// theirs: (slot, its confirmed checksum of that frame) of every peer that answered.
std::optional<PlayerId> recovery_source(PlayerId me, std::uint64_t mine,
                                        std::span<const std::pair<PlayerId, std::uint64_t>> theirs, DesyncKeep keep);

}  // namespace lockroll::rollback
