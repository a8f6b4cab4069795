// The echo baseline's runs (relay_bench --echo, --echo-batch): bench/udp_echo loaded at a server
// run's UDP datagram rate, its CPU the baseline of the server's.
#pragma once

#include <string>

#include "bench/relay_bench.h"

namespace lockroll::bench {

// The echo baseline's run, paired with a server run: bench/udp_echo (pinned and niced as the
// server; with batch > 0, udp_echo --batch batch) loaded at rate UDP datagrams a second, sent as the generator sends (o.hosts sockets,
// each firing once per tick at its own phase of the tick, the datagrams of a fire in one
// sendmmsg: the generator's cost is not what is measured), its replies drained. Its CPU
// (utime + stime) over o.seconds after one second of warm-up.
EchoResult run_echo(const Options& o, double rate, int batch, const std::string& dir);

// An echo run kept up when it was sent at least 99 % of the rate asked and sent back at least
// 99 % of what it was sent: one that fell behind (the machine stalled it, its buffer overflowed)
// spent less CPU on fewer datagrams, and its ratio to the server's would flatter the server.
inline bool echo_kept_up(const EchoResult& e, double rate) { return e.in_per_s >= 0.99 * rate && e.out_per_s >= 0.99 * e.in_per_s; }

}  // namespace lockroll::bench
