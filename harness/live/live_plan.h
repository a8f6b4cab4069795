// What one `lockroll live` run is to do: the flags as given (LiveOptions) and as checked and
// resolved before any process starts (LivePlan: modes, input delay per mode, the virtual-time
// match of the same flags, kills, joins, injections, clock skews, whether proxies stand between
// the processes). Plain data: the command (harness/live_command.cpp) parses and checks the
// flags into a plan, which the orchestration (live_processes.h) and the report (live_report.h)
// read. Contract: every field of a LivePlan has been checked (bad flags never reach a process).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "harness/match/match.h"

namespace lockroll::harness {

struct LiveOptions {
    std::string topology = "p2p";
    int players = 2;
    int frames = 720;
    int tick_rate = 60;
    std::string scene = "paper";
    std::string bot = "random";
    double latency = 0, jitter = 0, loss = 0, burst = 0, duplicate = 0, reorder = 0;
    std::uint64_t seed = 1;
    std::string mode = "both";
    std::string input_delay = "auto";
    int prediction = 8;
    std::vector<std::string> kills, rejoins, joins, injections;
    std::vector<std::string> restarts;  // SLOT@FRAME: a killed slot started again without --join
    int spectators = 0;
    int spectate_at = 0;  // frame of the first player at which spectators start (0: at once)
    bool view = false;    // also write each mode's view.html
    std::string out = "out/live";
    std::string log_level = "info";
    bool no_virtual = false;
    double disconnect_timeout = 5;
    double finish_timeout = 15;  // passed to every process: seconds after the last frame to wait for all
    int recoveries = 0;
    bool prediction_given = false;
    std::vector<std::string> clock_skews;  // SLOT=PPM (fault test)
    std::vector<std::string> partitions;   // --partition values, passed to every proxy
    int corrupt_snapshot = 0, truncate_snapshot = 0;  // fault tests, on every player from frame 0
};

struct Kill {
    int slot = 0;
    int frame = 0;
};

struct LivePlan {
    LiveOptions o;
    std::vector<Mode> modes;
    RunConfig base;                        // the same match for the virtual-time run
    std::map<Mode, int> input_delay;
    std::vector<Kill> kills, rejoins, joins;  // SLOT@FRAME
    std::vector<Kill> restarts;               // SLOT@FRAME: like rejoins, but with its usual arguments
    std::vector<std::string> injections;  // CLIENT:FRAME:BODY[:FIELD:BIT], for every peer
    std::map<int, int> clock_skew_ppm;    // slot -> ppm, for every process of that slot
    bool proxied = false;
    std::vector<bool> topologies;  // false: peer to peer, true: through the relay server
};

}  // namespace lockroll::harness
