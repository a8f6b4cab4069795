// overclaims on its own: a completed outcome holds only with exit 0, the last frame shown and
// confirmed, a final checksum and no kill; other outcomes claim nothing to check.
#include <gtest/gtest.h>

#include "harness/outcome_claims.h"

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

}  // namespace
}  // namespace lockroll::harness
