// Registers every subcommand of the lockroll program.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_all_commands(CLI::App& app);

}  // namespace lockroll::harness
