#include "rollback/desync_evidence.h"

namespace lockroll::rollback {

std::string desync_evidence_file_name(PlayerId client, const DesyncReport& report) {
    return "desync-client" + std::to_string(client) + "-peer" + std::to_string(report.peer) + "-frame" +
           std::to_string(report.frame) + ".txt";
}

std::string desync_evidence_text(const DesyncReport& report, const Simulation& simulation) {
    if (report.local_state.empty()) return {};
    return report.summary + "\n" + simulation.describe_state(report.local_state);
}

}  // namespace lockroll::rollback
