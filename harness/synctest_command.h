// `lockroll synctest`: sync-test mode (rollback/sync_test.h) on a scene, driven by input bots.
// Every frame rolls back --distance frames and resimulates them; exit 0 when every resimulated
// checksum matched, 1 naming the first nondeterministic frame, 2 for bad options or scene.
// --record FILE also writes the run as a replay, which `lockroll replay` can verify later.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_synctest_command(CLI::App& app);

}  // namespace lockroll::harness
