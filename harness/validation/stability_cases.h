// The cases of the numerical stability suite (docs/stability.md) and their criteria. Each case
// runs a scene (harness/scenes/stability/ or a shipped one) and returns its checks: every
// criterion with the figure measured beside it, and figures reported without a criterion.
// Figures are read exactly from Q32.32 into long double and never fed back into a World. No
// CLI and no output: `lockroll stability` (harness/stability_command.h) chooses, runs and
// prints them; tests may run a case directly.
#pragma once

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace lockroll::harness::stability {

struct Check {
    std::string what;
    std::string criterion;  // empty: reported only
    std::string figure;
    bool pass = true;
};

struct Outcome {
    std::vector<Check> checks;
    nlohmann::json details = nlohmann::json::object();
    bool pass() const {
        return std::all_of(checks.begin(), checks.end(), [](const Check& c) { return c.pass; });
    }
    void check(std::string what, std::string criterion, std::string figure, bool pass) {
        checks.push_back({std::move(what), std::move(criterion), std::move(figure), pass});
    }
    void report(std::string what, std::string figure) { checks.push_back({std::move(what), "", std::move(figure), true}); }
};

struct Case {
    std::string name;
    std::string title;
    bool soak = false;         // long: CTest runs it under the "soak" label only
    bool known_limit = false;  // a failure is reported as KNOWN-LIMIT (docs/stability.md says why)
    std::function<Outcome()> run;
};

// Every case, in the suite's order (docs/stability.md numbers them so).
std::vector<Case> all_cases();

}  // namespace lockroll::harness::stability
