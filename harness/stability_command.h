// `lockroll stability [--case NAME] [--json FILE] [--list]`: the numerical stability suite
// (docs/stability.md). Each case is a scene under harness/scenes/stability/ (or a shipped
// scene) plus its criteria (harness/validation/stability_cases.h); this command chooses, runs
// and prints every criterion with the figure measured beside it (--json writes them too). Exit
// status 0 when every case passes (or is a documented known limit), 1 when any fails, 2 on bad
// usage (an unknown case, an unwritable --json path), before any case runs.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_stability_command(CLI::App& app);

}  // namespace lockroll::harness
