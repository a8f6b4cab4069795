// relay_bench's load generator: R two-player rooms of bot clients against one relay server,
// speaking the relay protocol directly (rollback/relay_messages.h) over ENet, and the relay delay
// they measure (bench/relay_bench.cpp says how).
#pragma once

#include <cstdint>
#include <string>

#include "bench/child_process.h"
#include "bench/relay_bench.h"
#include "bench/relay_logs.h"

namespace lockroll::bench {

// One run: connects `rooms` rooms (run_id keeps their room ids apart from other runs') to the
// server at host:port, waits until every room is live and warm, then measures for o.seconds;
// the server's CPU, RSS and counters from `server` (pid 0: none). Every replaced slot-frame goes
// to log, the relay delay and the generator's lateness to delay_log.
RunResult run_generator(const Options& o, int rooms, const std::string& host, std::uint16_t port, std::uint64_t run_id,
                        ReplacedLog& log, DelayLog& delay_log, const ServerChild& server);

}  // namespace lockroll::bench
