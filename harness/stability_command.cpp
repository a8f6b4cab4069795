#include "harness/stability_command.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/report/output_path.h"
#include "harness/validation/stability_cases.h"

namespace lockroll::harness {

namespace {
using nlohmann::json;
using stability::Case;
using stability::Check;
using stability::Outcome;
using stability::all_cases;

struct StabilityOptions {
    std::vector<std::string> cases;
    std::string json_path;
    bool list = false;
};

int run_stability(const StabilityOptions& opt) {
    const std::vector<Case> cases = all_cases();
    if (opt.list) {
        for (const Case& c : cases) std::printf("%-14s %s%s\n", c.name.c_str(), c.title.c_str(), c.soak ? " [soak]" : "");
        return 0;
    }
    std::vector<const Case*> chosen;
    for (const std::string& name : opt.cases) {
        auto it = std::find_if(cases.begin(), cases.end(), [&](const Case& c) { return c.name == name; });
        if (it == cases.end()) {
            std::string known;
            for (const Case& c : cases) known += (known.empty() ? "" : ", ") + c.name;
            throw UsageError("--case: no stability case named \"" + name + "\" (cases: " + known + ")");
        }
        chosen.push_back(&*it);
    }
    if (chosen.empty())
        for (const Case& c : cases) chosen.push_back(&c);
    if (!opt.json_path.empty()) check_output_file("--json", opt.json_path);

    json out = json::array();
    int failed = 0;
    for (const Case* c : chosen) {
        const Outcome r = c->run();
        const bool pass = r.pass();
        const char* verdict = pass ? "PASS" : c->known_limit ? "KNOWN-LIMIT" : "FAIL";
        if (!pass && !c->known_limit) ++failed;
        std::printf("%-14s %-11s %s\n", c->name.c_str(), verdict, c->title.c_str());
        json checks = json::array();
        for (const Check& k : r.checks) {
            std::printf("    %-4s %-78s %-22s %s\n", k.criterion.empty() ? "" : (k.pass ? "ok" : "FAIL"), k.what.c_str(),
                        k.criterion.empty() ? "(reported)" : k.criterion.c_str(), k.figure.c_str());
            checks.push_back({{"what", k.what}, {"criterion", k.criterion}, {"figure", k.figure}, {"pass", k.pass}});
        }
        std::fflush(stdout);
        out.push_back({{"case", c->name}, {"title", c->title}, {"result", verdict}, {"checks", checks}, {"details", r.details}});
    }
    std::printf("%d of %zu cases failed\n", failed, chosen.size());
    if (!opt.json_path.empty()) write_file_atomic(opt.json_path, out.dump(2) + "\n");
    return failed == 0 ? 0 : 1;
}

}  // namespace

void add_stability_command(CLI::App& app) {
    auto opts = std::make_shared<StabilityOptions>();
    CLI::App* cmd = app.add_subcommand("stability", "Numerical stability suite: stiff and extreme cases (docs/stability.md)");
    cmd->add_option("--case", opts->cases, "Run only this case (repeatable); see --list");
    cmd->add_option("--json", opts->json_path, "Also write every case's checks and figures as JSON to this file");
    cmd->add_flag("--list", opts->list, "List the cases and exit");
    cmd->callback([opts] {
        // A failing case is a result, not an error: main turns this into exit status 1.
        if (run_stability(*opts) != 0) throw std::runtime_error("stability suite: a case failed (see above)");
    });
}

}  // namespace lockroll::harness
