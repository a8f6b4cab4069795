// Running the plotting scripts (scripts/plot.py, scripts/plot_precision.py) with Debian's
// python3 and matplotlib. Plots are a convenience: the CSV and JSON they read are written first,
// so a missing script or library costs the pictures, never the data.
#pragma once

#include <string>
#include <vector>

namespace lockroll::harness {

// Runs `/usr/bin/python3 SCRIPT ARGS...` with the Agg backend. The script is looked for in
// $LOCKROLL_SCRIPTS_DIR, the source tree's scripts/ and the installed share/lockroll/scripts.
// Returns "" on success, else why there are no plots (script missing, non-zero exit status).
std::string run_plot_script(const std::string& script, const std::vector<std::string>& args);

}  // namespace lockroll::harness
