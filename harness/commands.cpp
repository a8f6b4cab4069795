#include "harness/commands.h"

#include "harness/sim_command.h"

namespace lockroll::harness {

void add_all_commands(CLI::App& app) {
    add_sim_command(app);
}

}  // namespace lockroll::harness
