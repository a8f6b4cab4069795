// The --partition flag of `lockroll run`, `compare`, `live` and `proxy`: the CLI speaks frames,
// transport/ speaks microseconds, and this is where one becomes the other.
//
// Syntax of one flag value: one or more cuts separated by ';', each SETS@FROM-UNTIL, where SETS
// is two or more comma-separated slot lists separated by '/' and FROM < UNTIL are frames:
//   --partition 0,1,2,3/4,5,6,7@200-800      slots 0-3 and 4-7 cannot reach each other from
//                                            frame 200 until frame 800 (exclusive)
//   --partition '0/1/2@60-120;0,1/2@300-360' two cuts in one value (or repeat the flag)
// Frame F is F * 1'000'000 / tick_rate microseconds after frame 0 (integer division); where
// frame 0 is on a clock is the caller's business (the match's start, a live run's start).
//
// Contract: throws UsageError "--partition '<value>': <the offending part>: <what is wrong>" for
// bad syntax, an empty set, overlapping sets, a slot outside 0..players-1 and FROM >= UNTIL;
// callers parse before any work starts. No flag values: an empty schedule.
#pragma once

#include <string>
#include <vector>

#include "transport/partition_schedule.h"

namespace lockroll::harness {

transport::PartitionSchedule parse_partitions(const std::vector<std::string>& values, int players, int tick_rate);

}  // namespace lockroll::harness
