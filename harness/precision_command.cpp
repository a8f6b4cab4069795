#include "harness/precision_command.h"

#include <memory>

#include "harness/validation/precision_sweep.h"

namespace lockroll::harness {

void add_precision_command(CLI::App& app) {
    auto opts = std::make_shared<PrecisionOptions>();
    CLI::App* cmd = app.add_subcommand(
        "precision", "Work-precision sweep: error against run time over dt, iterations and substeps (docs/stability.md)");
    cmd->add_option("--out", opts->out, "Directory for precision.csv and precision.png");
    cmd->add_flag("--quick", opts->quick, "A small sweep (2 rates x 2 iteration counts x 2 substep counts), for tests");
    cmd->add_flag("--no-plot", opts->no_plot, "Write the CSV only");
    cmd->add_option("--reps", opts->reps, "Timed repetitions per setting (the fastest counts)")->check(CLI::Range(1, 100));
    cmd->callback([opts] { run_precision_sweep(*opts); });
}

}  // namespace lockroll::harness
