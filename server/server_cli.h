// `lockroll server` and `lockroll-server`: one set of options for both (CLI11).
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::server {

// Adds the `server` options to `cmd` and makes its callback run the server process. Bad options
// are reported by CLI11 (exit 2) before anything binds.
void add_server_options(CLI::App& cmd);

}  // namespace lockroll::server
