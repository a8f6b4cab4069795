// `lockroll proxy --listen [HOST:]PORT --to HOST:PORT [--latency MS --jitter MS --loss P --burst P
// --duplicate P --reorder P --seed N] [--duration-s S]`: a UDP impairment proxy
// (net/udp_proxy.h) for real processes on loopback. The network flags mean what they mean in
// `lockroll run` (the same link model, the same mapping: harness/match/match.h link_for).
//
// Prints "lockroll proxy: listening on ADDR -> ADDR" to stdout once bound (with --listen 0 the
// line names the port the OS chose), serves until SIGTERM/SIGINT or --duration-s, then prints
// its counters to stderr and exits 0. Bad flags, or an address outside 127.0.0.0/8 and ::1,
// exit 2 naming the flag before anything is bound.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_proxy_command(CLI::App& app);

}  // namespace lockroll::harness
