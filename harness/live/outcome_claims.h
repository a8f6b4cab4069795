// Whether what a process of `lockroll live` says it did holds against what the harness saw it
// do. A process that says "completed" must have exited 0 having shown and confirmed the last
// frame with a final checksum, must not have been killed, must not be in an unhealed partition
// (partitioned_since_frame without a later rejoined_at_frame: a healed minority rejoins the
// majority's view by snapshot) and may say "alone" (alone_since_frame) only when its view was
// reduced to itself (running_voters: its own slot only; without that list, only in a match of
// two): the two-player rule, in a match of two or of more shrunk to two (issue 21). One
// that says "partitioned" must name the frame and must not have exited 0. live fails on any
// claim that does not hold, as on differing final checksums.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lockroll::harness {

struct ProcessSeen {
    std::string name;            // e.g. "p2-rejoin"
    nlohmann::json summary;      // its summary.json; null when it left none
    bool killed = false;
    int killed_at_frame = -1;
    int exit_status = -1;
};

// One line per claim that does not hold (empty: every claim holds).
std::vector<std::string> overclaims(const ProcessSeen& p, int frames);

}  // namespace lockroll::harness
