#include "rollback/session_event.h"

#include <utility>

namespace lockroll::rollback {

const char* event_name(SessionEvent::Kind k) {
    using K = SessionEvent::Kind;
    switch (k) {
        case K::Synchronizing: return "synchronizing";
        case K::Synchronized: return "synchronized";
        case K::Refused: return "refused";
        case K::Interrupted: return "interrupted";
        case K::Resumed: return "resumed";
        case K::Disconnected: return "disconnected";
        case K::Partitioned: return "partitioned";
        case K::NeutralFrom: return "neutral_from";
        case K::Joined: return "joined";
        case K::SpectatorJoined: return "spectator_joined";
        case K::SnapshotLoaded: return "snapshot_loaded";
        case K::SnapshotRejected: return "snapshot_rejected";
        case K::DesyncDetected: return "desync";
        case K::DesyncRecovered: return "desync_recovered";
        case K::Kicked: return "kicked";
        case K::Failed: return "failed";
        case K::Draining: return "server_draining";
        case K::DesyncReport: return "desync_report";
        case K::ServerLost: return "server_lost";
    }
    return "unknown";
}

void EventQueue::push(SessionEvent e) {
    if (events_.size() >= kCapacity) {
        events_.pop_front();
        ++dropped_;
    }
    events_.push_back(std::move(e));
}

bool EventQueue::pop(SessionEvent& out) noexcept {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

}  // namespace lockroll::rollback
