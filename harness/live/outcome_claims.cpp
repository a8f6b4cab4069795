#include "harness/live/outcome_claims.h"

namespace lockroll::harness {

std::vector<std::string> overclaims(const ProcessSeen& p, int frames) {
    std::vector<std::string> out;
    const nlohmann::json& s = p.summary;
    if (!s.is_object()) return out;
    const std::string outcome = s.value("outcome", "");
    const auto why = [&](const std::string& w) { out.push_back(p.name + ": outcome " + outcome + ", but " + w); };
    if (outcome == "partitioned") {
        // A partition is a report, not a success: it must say since when, and not exit 0.
        if (!s.contains("partitioned_since_frame") || !s["partitioned_since_frame"].is_number())
            why("no partitioned_since_frame");
        if (p.exit_status == 0) why("exit status 0");
        return out;
    }
    if (outcome != "completed") return out;
    if (p.killed) why("it was killed at frame " + std::to_string(p.killed_at_frame));
    if (p.exit_status != 0) why("exit status " + std::to_string(p.exit_status));
    if (!s.contains("final_checksum") || !s["final_checksum"].is_string()) why("no final checksum");
    if (s.value("confirmed_frame", 0) < frames) why("confirmed only frame " + std::to_string(s.value("confirmed_frame", 0)));
    if (s.value("shown_frame", 0) < frames) why("showed only frame " + std::to_string(s.value("shown_frame", 0)));
    // A completion from inside an unhealed partition would claim an agreement nobody made.
    if (s.contains("partitioned_since_frame"))
        why("partitioned since frame " + s["partitioned_since_frame"].dump() + " and not healed");
    // Playing on alone is the two-player rule; with three or more every drop is a majority's.
    if (s.contains("alone_since_frame") && s.value("players", 2) > 2)
        why("alone since frame " + s["alone_since_frame"].dump() + " in a match of " + std::to_string(s.value("players", 2)) +
            " players");
    return out;
}

}  // namespace lockroll::harness
