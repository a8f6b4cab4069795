// Which process plays a slot (config.slot_hosts: a process may play several slots, its guests).
// One definition for the session and the parts that read its config.
#pragma once

#include "rollback/session.h"

namespace lockroll::rollback {

// The slot whose process plays `slot`: itself unless config.slot_hosts says otherwise (a slot
// out of range is its own host).
inline PlayerId host_of(const SessionConfig& config, PlayerId slot) {
    return config.slot_hosts.empty() || slot >= static_cast<PlayerId>(config.players) ? slot : config.slot_hosts[slot];
}

}  // namespace lockroll::rollback
