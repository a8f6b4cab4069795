// admit_hello (rollback/session_admission.h) on its own: each check of a hello, in order, and
// what a restarted process, a handed-over slot and a dropped slot get.
#include "rollback/session_admission.h"

#include <gtest/gtest.h>

using namespace lockroll::rollback;

namespace {

// A running session hears player 1, welcomed before as process 77, in the epoch it runs in.
HelloContext running_context() {
    HelloContext c;
    c.match_id = 0xC0FFEE;
    c.scene_checksum = 0x5CE4E;
    c.from = 1;
    c.from_slot = true;
    c.running = true;
    c.welcomed = true;
    c.incarnation = 77;
    c.slot_running = true;
    c.welcomed_in_this_epoch = true;
    c.interrupt_us = 750000;
    c.silent_us = 10000;  // it plays: heard 10 ms ago
    return c;
}

// The same, but player 1's process has not been heard for half the interruption time: a hello
// from another process of it may be a restart.
HelloContext quiet_context() {
    HelloContext c = running_context();
    c.silent_us = restart_quiet_us(c.interrupt_us);
    return c;
}

HelloMessage hello(Role role, std::uint64_t incarnation = 77) {
    HelloMessage m;
    m.match_id = 0xC0FFEE;
    m.scene_checksum = 0x5CE4E;
    m.role = role;
    m.incarnation = incarnation;
    return m;
}

}  // namespace

TEST(SessionAdmission, TheSameProcessAgainIsWelcomed) {
    const HelloAdmission a = admit_hello(hello(Role::Player), running_context());
    EXPECT_EQ(a.refusal, Refusal::None);
    EXPECT_TRUE(a.why.empty());
    EXPECT_FALSE(a.restarted);
}

TEST(SessionAdmission, VersionMatchAndSceneAreCheckedInThatOrderWithBothValues) {
    HelloMessage m = hello(Role::Player);
    m.version = kProtocolVersion + 1;
    m.match_id = 5;
    m.scene_checksum = 6;
    HelloAdmission a = admit_hello(m, running_context());
    EXPECT_EQ(a.refusal, Refusal::Version);
    EXPECT_EQ(a.why, "protocol version " + std::to_string(kProtocolVersion + 1) + ", ours " + std::to_string(kProtocolVersion));
    m.version = kProtocolVersion;
    a = admit_hello(m, running_context());
    EXPECT_EQ(a.refusal, Refusal::MatchId);
    EXPECT_EQ(a.why, "match id 5, ours " + std::to_string(0xC0FFEE));
    m.match_id = 0xC0FFEE;
    a = admit_hello(m, running_context());
    EXPECT_EQ(a.refusal, Refusal::Scene);
    EXPECT_EQ(a.why, "scene checksum 6, ours " + std::to_string(0x5CE4E));
}

TEST(SessionAdmission, ARoleThatDoesNotFitThePeerIdIsRefused) {
    const HelloAdmission a = admit_hello(hello(Role::Spectator), running_context());
    EXPECT_EQ(a.refusal, Refusal::BadRole);
    EXPECT_EQ(a.why, "role does not fit peer id 1");
    HelloContext spectator_id = running_context();
    spectator_id.from = 5;
    spectator_id.from_slot = false;
    EXPECT_EQ(admit_hello(hello(Role::Player), spectator_id).refusal, Refusal::BadRole);
    EXPECT_EQ(admit_hello(hello(Role::Joiner), spectator_id).refusal, Refusal::BadRole);
    EXPECT_EQ(admit_hello(hello(Role::Spectator), spectator_id).refusal, Refusal::None);
}

TEST(SessionAdmission, NewcomersRetryUntilThisSessionRuns) {
    HelloContext c = running_context();
    c.running = false;
    EXPECT_EQ(admit_hello(hello(Role::Joiner, 78), c).refusal, Refusal::Retry);
    EXPECT_FALSE(admit_hello(hello(Role::Joiner, 78), c).restarted);
    c.from = 5;
    c.from_slot = false;
    EXPECT_EQ(admit_hello(hello(Role::Spectator), c).refusal, Refusal::Retry);
    // A player's hello in the sync phase is the handshake itself.
    HelloContext syncing = running_context();
    syncing.running = false;
    syncing.welcomed = false;
    EXPECT_EQ(admit_hello(hello(Role::Player), syncing).refusal, Refusal::None);
}

TEST(SessionAdmission, ADroppedSlotIsToldSoAndMayRejoinAsAJoiner) {
    HelloContext c = running_context();
    c.slot_running = false;
    const HelloAdmission a = admit_hello(hello(Role::Player), c);
    EXPECT_EQ(a.refusal, Refusal::Disconnected);
    EXPECT_EQ(a.why, "slot 1 was dropped; rejoin as a joiner");
    EXPECT_EQ(admit_hello(hello(Role::Joiner, 78), c).refusal, Refusal::None);
    // Never welcomed (it never played here): not "dropped".
    c.welcomed = false;
    EXPECT_EQ(admit_hello(hello(Role::Player), c).refusal, Refusal::None);
}

TEST(SessionAdmission, AJoinerFromAnotherProcessOfARunningSlotMeansItRestarted) {
    const HelloAdmission a = admit_hello(hello(Role::Joiner, 78), quiet_context());
    EXPECT_EQ(a.refusal, Refusal::Retry);
    EXPECT_TRUE(a.restarted);
    EXPECT_TRUE(a.why.empty());
    // The same process as a joiner: a repeated hello, not a restart.
    EXPECT_FALSE(admit_hello(hello(Role::Joiner, 77), running_context()).restarted);
    // Running in a newer epoch than welcomed in, or handed over by us: the joiner itself.
    HelloContext newer = running_context();
    newer.welcomed_in_this_epoch = false;
    EXPECT_EQ(admit_hello(hello(Role::Joiner, 78), newer).refusal, Refusal::None);
    HelloContext handed = running_context();
    handed.handed_off_by_me = true;
    EXPECT_EQ(admit_hello(hello(Role::Joiner, 78), handed).refusal, Refusal::None);
    // Before this session runs it is a newcomer to retry, not a restart.
    HelloContext syncing = running_context();
    syncing.running = false;
    EXPECT_FALSE(admit_hello(hello(Role::Joiner, 78), syncing).restarted);
}

TEST(SessionAdmission, APlayerFromAnotherProcessOfARunningSlotMustRejoinAsAJoiner) {
    const HelloAdmission a = admit_hello(hello(Role::Player, 78), quiet_context());
    EXPECT_EQ(a.refusal, Refusal::Disconnected);  // it cannot start at frame 0 of a running match
    EXPECT_TRUE(a.restarted);                     // the old process is dropped first
    EXPECT_EQ(a.why, "slot 1 restarted; rejoin as a joiner");
    // Only ever heard its welcomes (incarnation unknown): cannot tell, welcomed as before.
    HelloContext unknown = running_context();
    unknown.incarnation = 0;
    EXPECT_EQ(admit_hello(hello(Role::Player, 78), unknown).refusal, Refusal::None);
    // Before this session runs, a player's hello is the handshake itself.
    HelloContext syncing = running_context();
    syncing.running = false;
    EXPECT_EQ(admit_hello(hello(Role::Player, 78), syncing).refusal, Refusal::None);
    EXPECT_FALSE(admit_hello(hello(Role::Player, 78), syncing).restarted);
}

// Issue 21: anyone can say hello with a slot's id. While the slot's process still talks (heard
// less than half the interruption time ago), a hello from another process of it is a claim
// refused "retry", flagged for counting and reported with why; nothing restarted. The same hello
// once that process has gone quiet is a restart (the session's vote).
TEST(SessionAdmission, ARestartClaimedWhileTheSlotsProcessStillTalksIsDoubted) {
    for (Role role : {Role::Joiner, Role::Player}) {
        const HelloAdmission a = admit_hello(hello(role, 78), running_context());
        EXPECT_EQ(a.refusal, Refusal::Retry);
        EXPECT_FALSE(a.restarted);
        EXPECT_TRUE(a.doubted);
        EXPECT_EQ(a.why, "slot 1 claimed to restart while its process was heard 10 ms ago");
        HelloContext almost = running_context();
        almost.silent_us = restart_quiet_us(almost.interrupt_us) - 1;
        EXPECT_TRUE(admit_hello(hello(role, 78), almost).doubted);
        const HelloAdmission q = admit_hello(hello(role, 78), quiet_context());
        EXPECT_TRUE(q.restarted);
        EXPECT_FALSE(q.doubted);
    }
    EXPECT_EQ(restart_quiet_us(750000), 375000u);
    // Its own process's hello again is no claim, however quiet the link.
    EXPECT_FALSE(admit_hello(hello(Role::Joiner, 77), running_context()).doubted);
    EXPECT_FALSE(admit_hello(hello(Role::Player, 77), quiet_context()).doubted);
}
