#include "harness/outcome_claims.h"

namespace lockroll::harness {

std::vector<std::string> overclaims(const ProcessSeen& p, int frames) {
    std::vector<std::string> out;
    const nlohmann::json& s = p.summary;
    if (!s.is_object() || s.value("outcome", "") != "completed") return out;
    const auto why = [&](const std::string& w) { out.push_back(p.name + ": outcome completed, but " + w); };
    if (p.killed) why("it was killed at frame " + std::to_string(p.killed_at_frame));
    if (p.exit_status != 0) why("exit status " + std::to_string(p.exit_status));
    if (!s.contains("final_checksum") || !s["final_checksum"].is_string()) why("no final checksum");
    if (s.value("confirmed_frame", 0) < frames) why("confirmed only frame " + std::to_string(s.value("confirmed_frame", 0)));
    if (s.value("shown_frame", 0) < frames) why("showed only frame " + std::to_string(s.value("shown_frame", 0)));
    return out;
}

}  // namespace lockroll::harness
