// `lockroll live`: a networked match of real processes on loopback, measured like `compare`.
// (Contract written with the implementation below.)
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_live_command(CLI::App& app);

}  // namespace lockroll::harness
