#include "rollback/session_admission.h"

namespace lockroll::rollback {

namespace {

// A restart claimed for a slot whose welcomed process still talks is refused: the claim counts
// only once that process has gone quiet (the contract). False when it is doubted.
bool quiet_enough(HelloAdmission& a, const HelloContext& c) {
    if (c.silent_us >= restart_quiet_us(c.interrupt_us)) return true;
    a.refusal = Refusal::Retry;
    a.doubted = true;
    a.why = "slot " + std::to_string(c.from) + " claimed to restart while its process was heard " +
            std::to_string(c.silent_us / 1000) + " ms ago";
    return false;
}

}  // namespace

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
        if (quiet_enough(a, c)) {
            a.refusal = Refusal::Retry;
            a.restarted = true;
        }
    } else if (m.role == Role::Player && c.slot_running && c.running && c.welcomed && c.incarnation != 0 &&
               c.incarnation != m.incarnation) {
        // A player hello from another process than the one welcomed: it restarted with its usual
        // settings. It cannot start at frame 0 of a running match: refused as dropped, it rejoins
        // by snapshot (net::NetSession restarts its session as a joiner). Incarnation 0: we only
        // ever heard its welcomes, never its hello, and cannot tell the processes apart.
        if (quiet_enough(a, c)) {
            a.refusal = Refusal::Disconnected;
            a.why = "slot " + std::to_string(c.from) + " restarted; rejoin as a joiner";
            a.restarted = true;
        }
    }
    return a;
}

}  // namespace lockroll::rollback
