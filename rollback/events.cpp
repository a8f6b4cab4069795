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

const char* reason_name(SessionEvent::Reason r) {
    using R = SessionEvent::Reason;
    switch (r) {
        case R::None: return "none";
        case R::TimedOut: return "timed_out";
        case R::TimedOutTwoPlayerRule: return "timed_out_two_player_rule";
        case R::KickVote: return "kick_vote";
        case R::KickVoteTwoPlayerRule: return "kick_vote_two_player_rule";
        case R::HandoffLapsed: return "handoff_lapsed";
        case R::HandoffLapsedTwoPlayerRule: return "handoff_lapsed_two_player_rule";
        case R::Restarted: return "restarted";
        case R::RestartedTwoPlayerRule: return "restarted_two_player_rule";
        case R::Rejoining: return "rejoining";
        case R::RejoiningTwoPlayerRule: return "rejoining_two_player_rule";
        case R::HostDropped: return "host_dropped";
        case R::SpectatorTimedOut: return "spectator_timed_out";
        case R::LearnedFromPeer: return "learned_from_peer";
        case R::ServerInputAbsent: return "server_input_absent";
        case R::VotedOut: return "voted_out";
        case R::SpectatorDropped: return "spectator_dropped";
        case R::KickedByServer: return "kicked_by_server";
        case R::Dropped: return "dropped";
        case R::Version: return "version";
        case R::MatchId: return "match_id";
        case R::Scene: return "scene";
        case R::SlotTaken: return "slot_taken";
        case R::Full: return "full";
        case R::BadRole: return "bad_role";
        case R::RestartDoubted: return "restart_doubted";
        case R::RoomParams: return "room_params";
        case R::BadSlot: return "bad_slot";
        case R::Spoof: return "spoof";
        case R::MatchEnded: return "match_ended";
        case R::TokenMissing: return "token_missing";
        case R::TokenInvalid: return "token_invalid";
        case R::TokenExpired: return "token_expired";
        case R::TokenMismatch: return "token_mismatch";
        case R::TokenInUse: return "token_in_use";
        case R::SlotOwned: return "slot_owned";
        case R::Silent: return "silent";
        case R::Heard: return "heard";
        case R::Reconnected: return "reconnected";
        case R::NoMajority: return "no_majority";
        case R::RoundTrip: return "round_trip";
        case R::LateWelcome: return "late_welcome";
        case R::RelayWelcome: return "relay_welcome";
        case R::Handshake: return "handshake";
        case R::FromSnapshot: return "from_snapshot";
        case R::Handoff: return "handoff";
        case R::ServerInputsStart: return "server_inputs_start";
        case R::WritesNeutral: return "writes_neutral";
        case R::NeutralAgreed: return "neutral_agreed";
        case R::Joining: return "joining";
        case R::Spectating: return "spectating";
        case R::Recovering: return "recovering";
        case R::TransferTimedOut: return "transfer_timed_out";
        case R::TransferInvalid: return "transfer_invalid";
        case R::TransferLoadFailed: return "transfer_load_failed";
        case R::TransferStalled: return "transfer_stalled";
        case R::ChecksumMismatch: return "checksum_mismatch";
        case R::ServerMinority: return "server_minority";
        case R::ServerNoMajority: return "server_no_majority";
        case R::Majority: return "majority";
        case R::TieRule: return "tie_rule";
        case R::RecoveryLimit: return "recovery_limit";
        case R::RoomMismatch: return "room_mismatch";
        case R::RoomRestarted: return "room_restarted";
        case R::StateTooLarge: return "state_too_large";
        case R::OfferTooLarge: return "offer_too_large";
        case R::Exception: return "exception";
        case R::ServerDraining: return "server_draining";
        case R::ServerSilent: return "server_silent";
        case R::SpectatorLagged: return "spectator_lagged";
    }
    return "unknown";
}

}  // namespace lockroll::rollback
