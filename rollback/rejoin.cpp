#include "rollback/rejoin.h"

#include <algorithm>

#include "rollback/session_impl.h"

namespace lockroll::rollback {

namespace {
// The process plays slots besides its own (SessionConfig::slot_hosts).
bool hosts_guests(const SessionConfig& c) {
    for (std::size_t s = 0; s < c.slot_hosts.size(); ++s)
        if (s != c.local_player && c.slot_hosts[s] == c.local_player) return true;
    return false;
}
}  // namespace

bool can_rejoin(const SessionConfig& c, bool kicked) { return kicked && rejoin_refusal(c).empty(); }

std::string rejoin_refusal(const SessionConfig& c) {
    if (c.role != Role::Spectator && hosts_guests(c))
        return "this process plays several slots (slot_hosts), and a joiner cannot host guest slots yet";
    return {};
}

std::string drop_failure(const SessionConfig& c) {
    std::string why = "dropped from the match by the other peers";
    if (const std::string no = rejoin_refusal(c); !no.empty()) why += "; it cannot rejoin: " + no;
    return why;
}

SessionConfig rejoin_config(const SessionConfig& c, std::uint64_t scene_checksum) {
    SessionConfig j = c;
    if (j.role != Role::Spectator) j.role = Role::Joiner;
    j.handshake = true;
    j.scene_checksum = scene_checksum;
    j.incarnation = 0;
    return j;
}

void carry_counters(const SessionStats& b, SessionStats& s) {
    s.ticks += b.ticks;
    s.frames_advanced += b.frames_advanced;
    s.stall_ticks += b.stall_ticks;
    s.stall_time_us += b.stall_time_us;
    s.rollbacks += b.rollbacks;
    s.resimulated_frames += b.resimulated_frames;
    s.max_rollback_depth = std::max(s.max_rollback_depth, b.max_rollback_depth);
    if (s.rollback_depth_histogram.size() < b.rollback_depth_histogram.size())
        s.rollback_depth_histogram.resize(b.rollback_depth_histogram.size(), 0);
    for (std::size_t d = 0; d < b.rollback_depth_histogram.size(); ++d) s.rollback_depth_histogram[d] += b.rollback_depth_histogram[d];
    s.resim_ns += b.resim_ns;
    s.forward_ns += b.forward_ns;
    s.predicted_inputs += b.predicted_inputs;
    s.dropped_local_inputs += b.dropped_local_inputs;
    s.bad_local_inputs += b.bad_local_inputs;
    s.time_sync_waits += b.time_sync_waits;
    s.time_sync_wait_frames += b.time_sync_wait_frames;
    s.desyncs += b.desyncs;
    s.bytes_sent += b.bytes_sent;
    s.bytes_received += b.bytes_received;
    s.packets_sent += b.packets_sent;
    s.packets_received += b.packets_received;
    s.malformed_packets += b.malformed_packets;
    s.unknown_peer_packets += b.unknown_peer_packets;
    s.drop_votes_unheeded += b.drop_votes_unheeded;
    // (oversized_states is not carried: a session that saved too much failed for that, not a drop.)
    if (s.peers.size() < b.peers.size()) s.peers.resize(b.peers.size());
    for (std::size_t p = 0; p < b.peers.size(); ++p) {
        const PeerStats& from = b.peers[p];
        PeerStats& to = s.peers[p];
        to.packets_sent += from.packets_sent;
        to.bytes_sent += from.bytes_sent;
        to.packets_received += from.packets_received;
        to.bytes_received += from.bytes_received;
        to.malformed_packets += from.malformed_packets;
        to.ignored_packets += from.ignored_packets;
        to.mispredictions += from.mispredictions;
        to.checksum_matches += from.checksum_matches;
        to.checksum_mismatches += from.checksum_mismatches;
        to.relay_disagreements += from.relay_disagreements;
    }
}

JoinerInput joiner_input(bool joining, std::uint32_t count, std::uint32_t local_target, std::uint32_t lead) {
    // Its frame + delay has met its stream: a player like any other from here.
    if (!joining || count <= local_target) return {};
    // One input per tick at the end of its stream (the others need them at the match's pace,
    // which its own frame may not keep yet), as long as that stays within the lead.
    if (count - local_target <= lead) return {true, count};
    // A lead ahead already: nothing new until its frame + delay comes within it (Sync adds
    // nothing below count). Still joining, so a tick without input is no dropped local input.
    return {true, 0};
}

void SessionImpl::continue_from(const SessionImpl& before) {
    carry_counters(before.stats_, stats_);
    last_frame_ = before.last_frame_;
    set_prediction_window(before.prediction_window());
}

}  // namespace lockroll::rollback
