// SessionQueries: what both sessions (the P2P Session, the RelaySession) answer alike about
// themselves -- phase, failure, frames, input delay, stalls, recoveries, stats, saved states,
// the event queue and the bit-flip fault hook. Both public facades derive from it; it reads the
// in-tree SessionCore (rollback/session_core.h) their state machines derive from, through a
// pointer the facade sets once in its constructor, so this installed header names none of it.
//
// Contract: every query is the SessionCore's, unchanged (rollback/session_core.h); the pointer
// is set before the facade's constructor returns, and again when Session::restart_as_joiner()
// replaces its state machine; it points at the facade's current state machine.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include <lockroll/rollback/session_event.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/telemetry.h>

namespace lockroll::rollback {

class SessionCore;  // rollback/session_core.h (in-tree)

class SessionQueries {
public:
    SessionPhase phase() const;
    bool running() const;
    // Why the session failed (phase() == Failed): "WHERE: WHY"; empty otherwise.
    const std::string& failure() const;
    std::uint32_t frame() const;
    std::uint32_t confirmed_frame() const;
    int input_delay() const;
    bool stalled() const;
    // Snapshot reloads after a desync so far.
    int recoveries() const;
    // Updated in place as the session runs.
    const SessionStats& stats() const;
    // Saved state of a frame while the ring holds it (confirmed frames are final).
    std::optional<std::span<const std::uint8_t>> saved_state(std::uint32_t frame) const;
    // Lifecycle events in order; false when none is left.
    bool next_event(SessionEvent& out) noexcept;
    // Fault injection: every time frame `frame` is produced by a step on this client, flip
    // `bit` of `field` of body `body_id`. Empty string on success, else why not (the frame is
    // already simulated, or the simulation has no such body/field).
    std::string inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit);

protected:
    SessionQueries() = default;
    ~SessionQueries() = default;
    SessionQueries(const SessionQueries&) = delete;
    SessionQueries& operator=(const SessionQueries&) = delete;

    SessionCore* core_ = nullptr;  // the facade's state machine, set by its constructor
};

}  // namespace lockroll::rollback
