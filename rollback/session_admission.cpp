#include "rollback/session_admission.h"

namespace lockroll::rollback {

HelloAdmission admit_hello(const HelloMessage& m, const HelloContext& c) {
    HelloAdmission a;
    if (m.version != kProtocolVersion) {
        a.refusal = Refusal::Version;
        a.why = "protocol version " + std::to_string(m.version) + ", ours " + std::to_string(kProtocolVersion);
    } else if (m.match_id != c.match_id) {
        a.refusal = Refusal::MatchId;
        a.why = "match id " + std::to_string(m.match_id) + ", ours " + std::to_string(c.match_id);
    } else if (m.scene_checksum != c.scene_checksum) {
        a.refusal = Refusal::Scene;
        a.why = "scene checksum " + std::to_string(m.scene_checksum) + ", ours " + std::to_string(c.scene_checksum);
    } else if ((m.role == Role::Spectator) == c.from_slot) {
        a.refusal = Refusal::BadRole;
        a.why = "role does not fit peer id " + std::to_string(c.from);
    } else if (!c.running && m.role != Role::Player) {
        a.refusal = Refusal::Retry;  // we cannot serve a snapshot before we run ourselves
    } else if (m.role == Role::Player && c.running && c.welcomed && !c.slot_running) {
        a.refusal = Refusal::Disconnected;
        a.why = "slot " + std::to_string(c.from) + " was dropped; rejoin as a joiner";
    } else if (m.role == Role::Joiner && c.slot_running && c.running && c.welcomed && c.incarnation != m.incarnation &&
               c.welcomed_in_this_epoch && !c.handed_off_by_me) {
        a.refusal = Refusal::Retry;
        a.restarted = true;
    }
    return a;
}

}  // namespace lockroll::rollback
