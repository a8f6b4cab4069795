#include "harness/report/plot_script.h"

#include <cstdlib>
#include <filesystem>

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;

fs::path find_script(const std::string& script) {
    std::vector<fs::path> dirs;
    if (const char* env = std::getenv("LOCKROLL_SCRIPTS_DIR")) dirs.emplace_back(env);
#ifdef LOCKROLL_SOURCE_SCRIPTS_DIR
    dirs.emplace_back(LOCKROLL_SOURCE_SCRIPTS_DIR);
#endif
#ifdef LOCKROLL_INSTALL_SCRIPTS_DIR
    dirs.emplace_back(LOCKROLL_INSTALL_SCRIPTS_DIR);
#endif
    for (const auto& d : dirs)
        if (fs::exists(d / script)) return d / script;
    return {};
}

// Single quotes around every argument; a quote inside one is closed, escaped and reopened.
std::string shell_quote(const std::string& s) {
    std::string out = "'";
    for (char c : s) {
        if (c == '\'')
            out.append("'\\''");
        else
            out.push_back(c);
    }
    out.push_back('\'');
    return out;
}
}  // namespace

std::string run_plot_script(const std::string& script, const std::vector<std::string>& args) {
    const fs::path path = find_script(script);
    if (path.empty()) return script + " not found (set LOCKROLL_SCRIPTS_DIR)";
    // Appends only: GCC 12 at -O3 warns falsely (-Wrestrict, PR 105329) on "literal" + string.
    std::string cmd = "MPLBACKEND=Agg /usr/bin/python3 ";
    cmd.append(shell_quote(path.string()));
    for (const auto& a : args) {
        cmd.push_back(' ');
        cmd.append(shell_quote(a));
    }
    const int rc = std::system(cmd.c_str());
    return rc == 0 ? "" : script + " exited with status " + std::to_string(rc);
}

}  // namespace lockroll::harness
