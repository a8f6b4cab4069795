// `lockroll precision [--out DIR] [--quick] [--no-plot]`: the work-precision sweep
// (docs/stability.md), run by harness/validation/precision_sweep.h; this file only reads the
// flags. The sweep runs three cases over time steps (240..20 Hz), solver iterations (1..16)
// and substeps (1..4) on the Q32.32 engine, times each setting, and measures its error against
// the same step algorithm on double (harness/validation/reference_world.h): trajectories against a fine
// reference for the non-chaotic cases, energy drift for the chaotic one. Writes
// DIR/precision.csv and, through scripts/plot_precision.py, DIR/precision.png.
#pragma once

#include <CLI/CLI.hpp>

namespace lockroll::harness {

void add_precision_command(CLI::App& app);

}  // namespace lockroll::harness
