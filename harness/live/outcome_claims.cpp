#include "harness/live/outcome_claims.h"

namespace lockroll::harness {

using nlohmann::json;

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
    // A completion from inside an unhealed partition would claim an agreement nobody made. Healed
    // by a rejoin (the majority dropped it; it loaded their snapshot), it completed on their view:
    // the rejoin must come after the partition it ends.
    if (s.contains("partitioned_since_frame")) {
        const json& since = s["partitioned_since_frame"];
        const json rejoined = s.value("rejoined_at_frame", json(nullptr));
        if (!rejoined.is_number())
            why("partitioned since frame " + since.dump() + " and not healed");
        else if (!since.is_number() || rejoined.get<double>() <= since.get<double>())
            why("partitioned since frame " + since.dump() + " and rejoined at frame " + rejoined.dump() + ", not after it");
    }
    // Playing on alone is the two-player rule: a drop in a view of two left this process the
    // only running player of its view, in a match of two or of more shrunk to two by drops
    // (issue 21). It says so with running_voters, its view's running processes at the end; a
    // view that still held others makes the claim false. An older summary without the list may
    // say alone only in a match of two.
    if (s.contains("alone_since_frame")) {
        const std::string alone = "alone since frame " + s["alone_since_frame"].dump();
        const json voters = s.value("running_voters", json(nullptr));
        if (voters.is_array()) {
            json others = json::array();
            for (const json& v : voters)
                if (v != s.value("slot", json(nullptr))) others.push_back(v);
            if (!others.empty() || voters.empty())
                why(alone + ", while its view still had " + (voters.empty() ? std::string("no running player") :
                                                               "slots " + others.dump() + " running"));
        } else if (s.value("players", 2) > 2) {
            why(alone + " in a match of " + std::to_string(s.value("players", 2)) +
                " players, and no running_voters says its view was reduced to itself");
        }
    }
    return out;
}

}  // namespace lockroll::harness
