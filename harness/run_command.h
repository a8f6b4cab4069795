// `lockroll run` (one mode), `lockroll compare` (lockstep and rollback on the same scene,
// network and seed) and `lockroll sweep` (input delay x prediction window x latency grid).
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_run_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_sweep_command(CLI::App& app);

}  // namespace lockroll::harness
