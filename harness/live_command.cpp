#include "harness/live_command.h"

namespace lockroll::harness {

void add_live_command(CLI::App&) {}

}  // namespace lockroll::harness
