// overclaims on its own: a completed outcome holds only with exit 0, the last frame shown and
// confirmed, a final checksum and no kill (nor an unhealed partition, nor "alone" while its view
// still held others); a partitioned one names its frame and exits non-zero; others claim nothing to check.
#include <gtest/gtest.h>

#include "harness/live/outcome_claims.h"

namespace lockroll::harness {
namespace {

ProcessSeen completed(int frame) {
    ProcessSeen p;
    p.name = "p1";
    p.exit_status = 0;
    p.summary = {{"outcome", "completed"}, {"final_checksum", "00000000000000ab"}, {"confirmed_frame", frame}, {"shown_frame", frame}};
    return p;
}

TEST(OutcomeClaims, ACompletedProcessThatDidCompleteClaimsNothingMore) {
    EXPECT_TRUE(overclaims(completed(300), 300).empty());
    EXPECT_TRUE(overclaims(completed(320), 300).empty());  // confirming past the last frame is fine
}

TEST(OutcomeClaims, EachUnheldPartOfACompletedClaimIsNamed) {
    ProcessSeen short_of = completed(250);
    const auto a = overclaims(short_of, 300);
    ASSERT_EQ(a.size(), 2u);
    EXPECT_NE(a[0].find("confirmed only frame 250"), std::string::npos);
    EXPECT_NE(a[1].find("showed only frame 250"), std::string::npos);

    ProcessSeen no_final = completed(300);
    no_final.summary["final_checksum"] = nullptr;
    ASSERT_EQ(overclaims(no_final, 300).size(), 1u);
    EXPECT_NE(overclaims(no_final, 300)[0].find("no final checksum"), std::string::npos);

    ProcessSeen killed = completed(300);
    killed.killed = true;
    killed.killed_at_frame = 120;
    killed.exit_status = 137;
    const auto k = overclaims(killed, 300);
    ASSERT_EQ(k.size(), 2u);
    EXPECT_EQ(k[0], "p1: outcome completed, but it was killed at frame 120");
    EXPECT_EQ(k[1], "p1: outcome completed, but exit status 137");
}

TEST(OutcomeClaims, OtherOutcomesAndMissingSummariesClaimNothing) {
    ProcessSeen failed = completed(100);
    failed.summary["outcome"] = "failed";
    failed.exit_status = 1;
    EXPECT_TRUE(overclaims(failed, 300).empty());
    ProcessSeen none;
    none.name = "p2";
    none.killed = true;
    EXPECT_TRUE(overclaims(none, 300).empty());
}

// Issue 21: a partitioned or lone process never says "completed" as if all agreed.
TEST(OutcomeClaims, ACompletionFromAnUnhealedPartitionIsAnOverclaim) {
    ProcessSeen p = completed(300);
    p.summary["partitioned_since_frame"] = 200;
    const auto c = overclaims(p, 300);
    ASSERT_EQ(c.size(), 1u);
    EXPECT_EQ(c[0], "p1: outcome completed, but partitioned since frame 200 and not healed");
}

// Issue 21, healed: a process the majority dropped while it was cut off rejoins its view by
// snapshot and may then complete; it says since when it had been partitioned and at which frame
// it rejoined. A rejoin frame that is not after the partition's is no rejoin of that episode.
TEST(OutcomeClaims, ACompletionAfterRejoiningTheMajoritysViewHolds) {
    ProcessSeen p = completed(900);
    p.summary["partitioned_since_frame"] = 200;
    p.summary["rejoined_at_frame"] = 640;
    EXPECT_TRUE(overclaims(p, 900).empty());
    ProcessSeen restarted = completed(900);  // rejoined without a partition (a restart)
    restarted.summary["rejoined_at_frame"] = 120;
    EXPECT_TRUE(overclaims(restarted, 900).empty());
    const auto claims_with_rejoin_at = [&p](const nlohmann::json& frame) {
        ProcessSeen q = p;
        q.summary["rejoined_at_frame"] = frame;
        return overclaims(q, 900);
    };
    EXPECT_EQ(claims_with_rejoin_at(150),
              std::vector<std::string>{"p1: outcome completed, but partitioned since frame 200 and rejoined at frame 150, not after it"});
    EXPECT_EQ(claims_with_rejoin_at(nullptr),
              std::vector<std::string>{"p1: outcome completed, but partitioned since frame 200 and not healed"});
}

TEST(OutcomeClaims, AloneWithoutItsViewHoldsOnlyInAMatchOfTwo) {
    ProcessSeen two = completed(300);
    two.summary["players"] = 2;
    two.summary["alone_since_frame"] = 150;
    EXPECT_TRUE(overclaims(two, 300).empty());
    ProcessSeen three = two;
    three.summary["players"] = 3;
    const auto c = overclaims(three, 300);
    ASSERT_EQ(c.size(), 1u);
    EXPECT_EQ(c[0], "p1: outcome completed, but alone since frame 150 in a match of 3 players, and no running_voters says its "
                    "view was reduced to itself");
}

// Issue 21: a match of three or more shrunk to two by drops plays the two-player rule too; a
// survivor whose view was reduced to itself truthfully says alone, whatever the match's size.
// While its view still held another running player, "alone" is an overclaim (in a match of two
// as well).
TEST(OutcomeClaims, AloneHoldsWhenItsViewWasReducedToItself) {
    ProcessSeen three = completed(1800);
    three.summary["players"] = 3;
    three.summary["slot"] = 1;
    three.summary["alone_since_frame"] = 426;
    three.summary["running_voters"] = {1};
    EXPECT_TRUE(overclaims(three, 1800).empty());
    ProcessSeen eight = three;
    eight.summary["players"] = 8;
    EXPECT_TRUE(overclaims(eight, 1800).empty());

    ProcessSeen others = three;
    others.summary["running_voters"] = {0, 1};
    EXPECT_EQ(overclaims(others, 1800),
              std::vector<std::string>{"p1: outcome completed, but alone since frame 426, while its view still had slots [0] running"});
    ProcessSeen two = others;
    two.summary["players"] = 2;
    EXPECT_EQ(overclaims(two, 1800).size(), 1u) << "a match of two whose view still holds the other is not alone";
    ProcessSeen none = three;
    none.summary["running_voters"] = nlohmann::json::array();
    EXPECT_EQ(overclaims(none, 1800),
              std::vector<std::string>{"p1: outcome completed, but alone since frame 426, while its view still had no running player"});
    ProcessSeen plain = three;  // the same view without the claim: a plain completion holds
    plain.summary.erase("alone_since_frame");
    EXPECT_TRUE(overclaims(plain, 1800).empty());
}

TEST(OutcomeClaims, APartitionedProcessNamesTheFrameAndDoesNotExitZero) {
    ProcessSeen p;
    p.name = "p2";
    p.exit_status = 1;
    p.summary = {{"outcome", "partitioned"}, {"partitioned_since_frame", 201}, {"confirmed_frame", 201}, {"shown_frame", 209}};
    EXPECT_TRUE(overclaims(p, 600).empty());
    // A joiner partitioned before it loaded anything (rollback/joiner_reach.h) says frame 0: a
    // frame all the same.
    ProcessSeen joiner = p;
    joiner.summary["partitioned_since_frame"] = 0;
    EXPECT_TRUE(overclaims(joiner, 600).empty());
    ProcessSeen no_frame = p;
    no_frame.summary.erase("partitioned_since_frame");
    no_frame.exit_status = 0;
    const auto c = overclaims(no_frame, 600);
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c[0], "p2: outcome partitioned, but no partitioned_since_frame");
    EXPECT_EQ(c[1], "p2: outcome partitioned, but exit status 0");
}

}  // namespace
}  // namespace lockroll::harness
