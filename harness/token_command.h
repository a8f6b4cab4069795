// `lockroll token`: connect tokens for a relay server started with --key (server/connect_token.h),
// as a matchmaker or backend would issue them, for the CLI and the tests.
//
//   lockroll token --new-key --key FILE      writes a fresh random key (refuses an existing FILE)
//   lockroll token --key FILE --room NAME --slot N [--spectate] [--client-id ID] [--expires-in S]
//                  [--players N] [--tick-rate T] [--scene S] [--absent SLOT...] --out TOKEN
//                                            seals a grant for that room and slot; the room
//                                            parameters (and the scene checksum, computed from
//                                            --scene as `lockroll client` does) must be the ones
//                                            the clients play with, or the server refuses them
// Prints one line: what was written. Exit status: 0 written, 2 bad flags or files (checked
// before anything is written), 1 failure.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_token_command(CLI::App& app);

}  // namespace lockroll::harness
