#include "rollback/events.h"

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

}  // namespace lockroll::rollback
