// A client's figures for the reports (metrics.h ClientResult) from its session's own counters,
// the same for a client of an in-process match and for a real process (`lockroll peer`). The
// caller adds what the session cannot know: the tick rate and stall fraction from when frames
// were shown (match_recorder.h tick_figures, one rule for both) and the final confirmed checksum.
#pragma once

#include "harness/match/metrics.h"
#include "rollback/session_types.h"

namespace lockroll::harness {

inline ClientResult client_result(const rollback::SessionStats& st) {
    ClientResult cr;
    cr.frames = st.frames_advanced;
    cr.ticks = st.ticks;
    cr.stall_ticks = st.stall_ticks;
    cr.time_sync_waits = st.time_sync_wait_frames;
    cr.rollbacks = st.rollbacks;
    cr.resimulated_frames = st.resimulated_frames;
    cr.max_rollback_depth = st.max_rollback_depth;
    cr.bytes_sent = st.bytes_sent;
    cr.bytes_received = st.bytes_received;
    cr.packets_sent = st.packets_sent;
    cr.packets_received = st.packets_received;
    for (const auto& p : st.peers) cr.mispredictions += p.mispredictions;
    cr.malformed_packets = st.malformed_packets;
    cr.desyncs = st.desyncs;
    return cr;
}

}  // namespace lockroll::harness
