#include "harness/commands.h"

#include "harness/live_command.h"
#include "harness/peer_command.h"
#include "harness/precision_command.h"
#include "harness/proxy_command.h"
#include "harness/replay_command.h"
#include "harness/run_command.h"
#include "harness/sim_command.h"
#include "harness/synctest_command.h"
#include "harness/token_command.h"
#include "harness/view_command.h"
#include "server/server_cli.h"
#include "harness/stability_command.h"

namespace lockroll::harness {

void add_all_commands(CLI::App& app) {
    add_sim_command(app);
    add_stability_command(app);
    add_precision_command(app);
    add_run_command(app);
    add_compare_command(app);
    add_sweep_command(app);
    add_replay_command(app);
    add_synctest_command(app);
    add_peer_command(app);
    add_live_command(app);
    // The relay server (server/): the same options as the standalone lockroll-server.
    server::add_server_options(*app.add_subcommand(
        "server", "The relay server: rooms that collect, confirm and broadcast inputs (runs no simulation)"));
    add_token_command(app);
    add_proxy_command(app);
    add_view_command(app);
}

}  // namespace lockroll::harness
