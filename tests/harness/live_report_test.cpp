// harness/live/live_report.h on hand-made process records: live.json's verdict (equal finals,
// survivors, a kill, a partition's cut-off side), a mode's figures when processes left nothing
// (named in the notes, counted in no figure, every figure n/a with its reason), and the
// topology table's relay-only cells. The whole report from real processes is
// tests/harness/live_report_test.sh.
#include "harness/live/live_report.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "harness/match/scene_loader.h"

namespace lockroll::harness {
namespace {

using nlohmann::json;

ProcessRecord player(int slot, const std::string& outcome, const std::string& final_checksum, int exit_status) {
    ProcessRecord r;
    r.slot = slot;
    r.name = "p";
    r.name += std::to_string(slot);  // (not "p" + ...: GCC 12 -O3 warns -Wrestrict on it, falsely)
    r.started = true;
    r.exit_status = exit_status;
    // The keys a real process's summary.json has; live_json must not depend on them
    // (SummaryWithoutItsKeysIsReadAsNotCollected).
    r.summary = {{"outcome", outcome},
                 {"final_checksum", final_checksum.empty() ? json(nullptr) : json(final_checksum)},
                 {"ticks_per_second", 60.0},
                 {"stall_fraction", 0.0},
                 {"longest_stall_ms", 16.7}};
    return r;
}

const std::filesystem::path kNoDir = std::filesystem::temp_directory_path() / "lockroll_live_report_test_none";

TEST(LiveJson, EqualFinalsAndCompletedSurvivorsAreOk) {
    const json j = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000aa", 0)}, kNoDir);
    EXPECT_TRUE(j["final_checksums_equal"].get<bool>());
    EXPECT_TRUE(j["survivors_completed"].get<bool>());
    EXPECT_TRUE(j["ok"].get<bool>());
    EXPECT_EQ(j["split"]["completed"].get<int>(), 2);
    ASSERT_EQ(j["processes"].size(), 2u);
    EXPECT_EQ(j["processes"][1]["role"], "player");
}

TEST(LiveJson, DifferentFinalsOrAFailedSurvivorAreNotOk) {
    const json differ = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000bb", 0)}, kNoDir);
    EXPECT_FALSE(differ["final_checksums_equal"].get<bool>());
    EXPECT_FALSE(differ["ok"].get<bool>());
    const json failed = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "failed", "", 1)}, kNoDir);
    EXPECT_FALSE(failed["survivors_completed"].get<bool>());
    EXPECT_FALSE(failed["ok"].get<bool>());
}

// Issue 21: two survivors of a view of two cut apart each play on alone and end on their own
// final. Saying "alone" they claim no agreement, so their finals are not held against each other
// (outcome_claims checks the claim against their views). Two plain completions on different
// finals still fail, with or without an alone one beside them.
TEST(LiveJson, FinalsOfProcessesThatSayAloneAreNotAnAgreement) {
    const auto alone = [](int slot, const std::string& final_checksum) {
        ProcessRecord r = player(slot, "completed", final_checksum, 0);
        r.summary["alone_since_frame"] = 426;
        return r;
    };
    const json split = live_json({alone(0, "00000000000000aa"), alone(1, "00000000000000bb")}, kNoDir);
    EXPECT_FALSE(split["final_checksums_equal"].get<bool>()) << "the fact: two finals";
    EXPECT_TRUE(split["agreeing_finals_equal"].get<bool>());
    EXPECT_EQ(split["alone"].get<int>(), 2);
    EXPECT_TRUE(split["ok"].get<bool>());

    const json one_alone = live_json({alone(0, "00000000000000aa")}, kNoDir);  // the 2-player kill
    EXPECT_TRUE(one_alone["final_checksums_equal"].get<bool>());
    EXPECT_TRUE(one_alone["ok"].get<bool>());

    const json plain = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000bb", 0),
                                  alone(2, "00000000000000cc")},
                                 kNoDir);
    EXPECT_FALSE(plain["agreeing_finals_equal"].get<bool>()) << "two plain completions on different finals";
    EXPECT_FALSE(plain["ok"].get<bool>());
    const json mixed =
        live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000aa", 0), alone(2, "00000000000000cc")},
                  kNoDir);
    EXPECT_TRUE(mixed["ok"].get<bool>());
}

TEST(LiveJson, AKilledProcessCountsInNoVerdict) {
    ProcessRecord killed = player(1, "", "", 137);
    killed.summary = json();  // a SIGKILLed process leaves no summary
    killed.killed = true;
    killed.killed_at_frame = 200;
    killed.killed_mono_us = 1000;
    const json j = live_json({player(0, "completed", "00000000000000aa", 0), killed}, kNoDir);
    EXPECT_TRUE(j["ok"].get<bool>());
    EXPECT_EQ(j["processes"][1]["outcome"], "killed");
    EXPECT_EQ(j["processes"][1]["killed_at_frame"].get<int>(), 200);
    // The survivor's stall after the kill: no events, so no synchronized time to count from.
    EXPECT_EQ(j["processes"][0]["longest_stall_after_kill_ms"].get<double>(), 0.0);
}

TEST(LiveJson, ASummaryWithoutItsKeysIsReadAsNotCollected) {
    // A summary.json cut short (or from another version) once crashed live_json: nlohmann's
    // const operator[] on a missing key is undefined behaviour.
    ProcessRecord bare = player(1, "completed", "", 0);
    bare.summary = {{"outcome", "completed"}};
    const json j = live_json({player(0, "completed", "00000000000000aa", 0), bare}, kNoDir);
    EXPECT_TRUE(j["processes"][1]["final_checksum"].is_null());
    EXPECT_TRUE(j["processes"][1]["ticks_per_second"].is_null());
    EXPECT_TRUE(j["processes"][1]["stall_fraction"].is_null());
    // (That a "completed" without a final checksum overclaims is outcome_claims' to say.)
    EXPECT_EQ(j["split"]["completed"].get<int>(), 2);
}

TEST(LiveJson, ThePartitionedSideIsASplitNotAFailure) {
    ProcessRecord cut = player(2, "partitioned", "", 1);
    cut.summary["partitioned_since_frame"] = 240;
    const json j = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000aa", 0), cut}, kNoDir);
    EXPECT_EQ(j["split"]["partitioned"].get<int>(), 1);
    EXPECT_EQ(j["split"]["partitioned_processes"], json::array({"p2"}));
    EXPECT_TRUE(j["ok"].get<bool>());
}

// A joiner (`--join`/`--rejoin`/`--restart`) that never reached a majority of the view ends
// partitioned since its confirmed frame, 0 when it loaded nothing (rollback/joiner_reach.h): the
// cut-off side of a split like any partitioned player, not a survivor that failed (before, it
// ended connect_timeout, and live failed the run).
TEST(LiveJson, AJoinerThatNeverReachedAMajorityIsTheCutOffSide) {
    ProcessRecord joiner = player(2, "partitioned", "", 1);
    joiner.name = "p2-rejoin";
    joiner.joiner = true;
    joiner.summary["partitioned_since_frame"] = 0;
    ProcessRecord killed = player(2, "", "", -1);
    killed.killed = true;
    const json j = live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000aa", 0), killed, joiner},
                             kNoDir);
    EXPECT_EQ(j["split"]["partitioned"].get<int>(), 1);
    EXPECT_EQ(j["split"]["partitioned_processes"], json::array({"p2-rejoin"}));
    EXPECT_TRUE(j["ok"].get<bool>());
    joiner.summary = {{"outcome", "connect_timeout"}};  // what it said before: a failure
    EXPECT_FALSE(live_json({player(0, "completed", "00000000000000aa", 0), player(1, "completed", "00000000000000aa", 0), killed, joiner},
                           kNoDir)["ok"]
                     .get<bool>());
}

// Issue 21, healed: the process cut off from the majority rejoined its view by snapshot and
// completed. It counts as completed (no split side), its record says when it had been cut off
// and when it rejoined, and live is ok only if its final is everyone's: a rejoined process on
// another final fails the run like any two completed finals that differ.
TEST(LiveJson, AProcessThatRejoinedAfterTheHealCountsAsCompletedOnTheMajoritysFinal) {
    const auto rejoined = [](const std::string& final_checksum) {
        ProcessRecord r = player(2, "completed", final_checksum, 0);
        r.summary["partitioned_since_frame"] = 200;
        r.summary["rejoined_at_frame"] = 640;
        return r;
    };
    const ProcessRecord p0 = player(0, "completed", "00000000000000aa", 0), p1 = player(1, "completed", "00000000000000aa", 0);
    const json j = live_json({p0, p1, rejoined("00000000000000aa")}, kNoDir);
    EXPECT_TRUE(j["ok"].get<bool>());
    EXPECT_TRUE(j["final_checksums_equal"].get<bool>());
    EXPECT_EQ(j["split"]["completed"].get<int>(), 3);
    EXPECT_EQ(j["split"]["partitioned"].get<int>(), 0);
    EXPECT_EQ(j["processes"][2]["partitioned_since_frame"].get<int>(), 200);
    ASSERT_TRUE(j["processes"][2].contains("rejoined_at_frame"));
    EXPECT_EQ(j["processes"][2]["rejoined_at_frame"].get<int>(), 640);
    EXPECT_TRUE(j["processes"][0]["rejoined_at_frame"].is_null());
    const json differ = live_json({p0, p1, rejoined("00000000000000bb")}, kNoDir);
    EXPECT_FALSE(differ["final_checksums_equal"].get<bool>());
    EXPECT_FALSE(differ["ok"].get<bool>());
}

TEST(LiveRunResult, ProcessesThatLeftNothingAreNamedAndEveryFigureIsNa) {
    LivePlan p;
    p.o.players = 2;
    p.o.frames = 60;
    p.base.scene = load_scene("paper");
    ProcessRecord killed = player(0, "", "", 137);
    killed.summary = json();
    killed.killed = true;
    killed.killed_at_frame = 30;
    ProcessRecord silent = player(1, "", "", 1);
    silent.summary = json();  // exited without a summary
    silent.failure = "lockroll: error: cannot create a host bound to 127.0.0.1:27589";
    ProcessRecord mute = player(1, "", "", 1);  // a failure whose log says nothing
    mute.name = "p1-again";
    mute.summary = json();
    const RunResult r = live_run_result(p, Mode::Rollback, kNoDir, {killed, silent, mute}, 2);
    EXPECT_FALSE(r.completed);
    EXPECT_TRUE(r.clients.empty());
    ASSERT_EQ(r.notes.size(), 3u);
    EXPECT_NE(r.notes[0].find("killed by --kill at frame 30, not rejoined"), std::string::npos) << r.notes[0];
    // The note quotes the process's own word on why, and names its log.
    EXPECT_NE(r.notes[1].find("left no summary (exit status 1: lockroll: error: cannot create a host bound to 127.0.0.1:27589; "
                              "its log: p1.stderr.log)"),
              std::string::npos)
        << r.notes[1];
    EXPECT_NE(r.notes[2].find("left no summary (exit status 1; its log: p1-again.stderr.log)"), std::string::npos) << r.notes[2];
    const json j = live_json({killed, silent, mute}, kNoDir);
    EXPECT_EQ(j["processes"][1]["failure"].get<std::string>(), silent.failure);
    EXPECT_EQ(j["processes"][2]["failure"].get<std::string>(), "");
    EXPECT_EQ(r.input_delay, 2);
    EXPECT_EQ(r.position_error.count, 0u);
    for (const char* field : {"position_error", "input_latency_local", "input_latency_remote", "measured_rtt"})
        EXPECT_TRUE(r.unmeasured.contains(field)) << field;
}

TEST(TopologyTable, ServerCellsOnlyForRelayRuns) {
    RunResult mesh, relay;
    const std::string t = topology_table({{"rollback", &mesh, json::object()},
                                          {"relay-rollback", &relay, {{"server", {{"bytes_in", 600}, {"bytes_out", 600}}}, {"replaced", 3}}}},
                                         120, 60);
    EXPECT_NE(t.find("| rollback |"), std::string::npos);
    // 1,200 bytes over 2 s of match: 600 B/s; 3 replaced inputs.
    EXPECT_NE(t.find("| 600 | 3 |"), std::string::npos) << t;
    EXPECT_NE(t.find("| - | - |"), std::string::npos) << t;
}

}  // namespace
}  // namespace lockroll::harness
