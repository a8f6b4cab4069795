// The desync evidence file: what a client writes once narrowing has named the first differing
// frame (DesyncReport with its saved state), so two clients' files can be diffed. One name and
// one content for every writer: `lockroll run` and `lockroll live` (harness/match, harness/
// peer_command) and net::SessionBuilder's desync_report_dir().
//
// Contract
//  - desync_evidence_file_name(): "desync-client<C>-peer<P>-frame<F>.txt", C the writer's own
//    slot (or spectator id), P the peer it disagrees with, F the first differing frame: unique
//    per (client, peer, frame), so both sides' files sit side by side in one directory.
//  - desync_evidence_text(): the report's one-line summary (it names body and field when
//    narrowing got that far), a newline, then the writer's state at F as the simulation
//    describes it (Simulation::describe_state; generic games get a hex dump). Nothing else.
//  - Pure: no file is opened here (rollback/ stays sans-IO); each writer writes the text with
//    its own file policy.
#pragma once

#include <string>

#include "rollback/events.h"
#include "rollback/session_types.h"
#include "rollback/simulation.h"

namespace lockroll::rollback {

std::string desync_evidence_file_name(PlayerId client, const DesyncReport& report);
// Empty when the report carries no state (the frame was no longer held): nothing to write.
std::string desync_evidence_text(const DesyncReport& report, const Simulation& simulation);

}  // namespace lockroll::rollback
