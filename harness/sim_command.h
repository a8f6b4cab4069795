// `lockroll sim`: run a scene offline and print its checksum every K frames.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_sim_command(CLI::App& app);

}  // namespace lockroll::harness
