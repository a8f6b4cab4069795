// `lockroll run` (one mode), `lockroll compare` (lockstep and rollback on the same scene,
// network and seed) and `lockroll sweep` (input delay x prediction window x latency grid).
#pragma once

#include <CLI/CLI.hpp>

#include "harness/match/match.h"
#include "sim/scene.h"

namespace lockroll::harness {

void add_run_command(CLI::App& app);
// --inject-desync CLIENT:FRAME:BODY[:FIELD:BIT] (run, compare, live, peer); UsageError naming
// the text when malformed.
DesyncInjection parse_injection(const std::string& text);
void add_compare_command(CLI::App& app);
void add_sweep_command(CLI::App& app);

}  // namespace lockroll::harness
