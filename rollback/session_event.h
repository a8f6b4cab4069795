// What a session (P2P or relay) tells its owner: one stream of typed events, each with the slot
// or peer it concerns, a frame and a detail, drained with next_event() (requests, not callbacks).
//
// EventQueue holds them until then. Contract: bounded by kCapacity; an owner that never drains
// them cannot make a session grow without bound, and when full the oldest event is dropped and
// counted in dropped(), so the newest (the one that says how the session ended) is never lost.
// One queue for both sessions (they held 4,096 and 1,024).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>

#include <lockroll/rollback/player_id.h>

namespace lockroll::rollback {

struct SessionEvent {
    enum class Kind : std::uint8_t {
        Synchronizing,   // peer answered a hello (frame: round trips so far)
        Synchronized,    // this session starts frame 0 (or its snapshot frame)
        Refused,         // a handshake failed; detail says why
        Interrupted,     // peer silent for interrupt_us
        Resumed,         // heard again
        Disconnected,    // slot dropped (frame: its inputs held here when dropped)
        Partitioned,     // this session votes others gone but hears no majority of the view: it
                         // drops nobody and stops confirming (frame: its confirmed frame); once
                         // per episode, over when it hears a majority again or a drop is agreed
        NeutralFrom,     // agreed: slot's input is the flagged neutral one from `frame`
        Joined,          // slot (re)joined; frame: the first frame of its own inputs
        SpectatorJoined,
        SnapshotLoaded,  // this session loaded a snapshot of `frame`
        SnapshotRejected,  // a transfer failed verification; asked again
        DesyncDetected,  // frame: first mismatching confirmed frame with `peer`
        DesyncRecovered, // this session reloaded the majority's state at `frame`
        Kicked,          // the others dropped this session's slot
        Failed,          // the session cannot go on; detail says why
        Draining,        // relay: the server is shutting down (the match may finish)
        DesyncReport,    // net::NetSession only (the builder): narrowing ended; peer, frame: the
                         // first differing frame; detail: the summary (body and field when found)
                         // and the evidence file written (desync_report_dir), if any
        ServerLost,      // relay: nothing from the server for server_timeout_us while in the room
                         // (killed, or cut off); detail says how long. The session then fails.
    };
    Kind kind = Kind::Synchronizing;
    PlayerId peer = 0;        // the slot or peer id concerned
    std::uint32_t frame = 0;
    std::uint64_t at_us = 0;
    std::string detail;
};
const char* event_name(SessionEvent::Kind k);

class EventQueue {
public:
    static constexpr std::size_t kCapacity = 4096;

    void push(SessionEvent e);
    // Takes the oldest event; false when there is none. Never throws.
    bool pop(SessionEvent& out) noexcept;
    std::size_t size() const { return events_.size(); }
    std::uint64_t dropped() const { return dropped_; }

private:
    std::deque<SessionEvent> events_;
    std::uint64_t dropped_ = 0;
};

}  // namespace lockroll::rollback
