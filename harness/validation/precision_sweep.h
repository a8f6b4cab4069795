// The work-precision sweep (docs/stability.md): three cases over time steps (240..20 Hz), solver
// iterations (1..16) and substeps (1..4) on the Q32.32 engine, each setting timed and measured
// against the same step algorithm on double (reference_world.h): trajectories against a fine
// reference for the non-chaotic cases, energy drift for the chaotic one. Writes OUT/precision.csv
// (and, unless no_plot, OUT/precision.png through scripts/plot_precision.py) and prints each
// setting and the Pareto front per case. No CLI: `lockroll precision`
// (harness/precision_command.h) fills the options.
//
// Contract: the output directory is checked before any work (UsageError naming --out); a plot
// that cannot be made throws std::runtime_error after the CSV is written.
#pragma once

#include <string>

namespace lockroll::harness {

struct PrecisionOptions {
    std::string out = "precision";
    bool quick = false;
    bool no_plot = false;
    int reps = 3;
};

void run_precision_sweep(const PrecisionOptions& o);

}  // namespace lockroll::harness
