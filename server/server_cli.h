// `lockroll server` and `lockroll-server`: one set of options for both (CLI11).
#pragma once

#include <CLI/CLI.hpp>

#include "server/server_process.h"

namespace lockroll::server {

// Adds the `server` options to `cmd` and makes its callback run the server process. Bad options
// are reported by CLI11 (exit 2) before anything binds. batching: lockroll-server's (its main
// links server/enet_socket_batching.cpp); `lockroll server` passes none.
void add_server_options(CLI::App& cmd, const SocketBatching& batching = {});

}  // namespace lockroll::server
