// RestartClaim (rollback/restart_claim.h) on its own: a hello's claim that a slot's process
// restarted counts only once it has stood, the old process unheard since it began, for the
// confirmation window, and is made again then; hearing the old process voids it.
#include "rollback/restart_claim.h"

#include <gtest/gtest.h>

namespace lockroll::rollback {
namespace {

constexpr std::uint64_t kConfirm = 375'000;

TEST(RestartClaim, TheWindowIsHalfTheInterruption) {
    EXPECT_EQ(restart_confirm_us(750'000), 375'000u);
    EXPECT_EQ(restart_confirm_us(0), 0u);
}

// A restarted process says hello again and again; its predecessor stays silent: the claim
// counts at the first hello once the window has passed since the first one, not before.
TEST(RestartClaim, CountsOnceItHasStoodTheWindowUnanswered) {
    RestartClaim c;
    const std::uint64_t heard = 1'000'000;  // the old process, last
    EXPECT_FALSE(c.claim(1'400'000, heard, kConfirm)) << "a new claim never counts at once";
    EXPECT_TRUE(c.stands(heard));
    EXPECT_EQ(c.since_us(), 1'400'000u);
    EXPECT_FALSE(c.claim(1'450'000, heard, kConfirm));
    EXPECT_FALSE(c.claim(1'774'999, heard, kConfirm));
    EXPECT_EQ(c.since_us(), 1'400'000u) << "later hellos keep the claim's start";
    EXPECT_TRUE(c.claim(1'775'000, heard, kConfirm));
    EXPECT_TRUE(c.claim(1'800'000, heard, kConfirm)) << "and it keeps counting";
}

// Issue 21: an outsider's hello lands in a genuine loss burst. The old process speaks again
// before the window is over: the claim is void, and the outsider's next hello starts a new one
// (the window again), however long the first has stood.
TEST(RestartClaim, TheOldProcessHeardAgainVoidsTheClaim) {
    RestartClaim c;
    EXPECT_FALSE(c.claim(1'450'000, 1'000'000, kConfirm));
    EXPECT_FALSE(c.stands(1'650'000)) << "heard 200 ms after the claim began";
    EXPECT_FALSE(c.claim(2'000'000, 1'650'000, kConfirm)) << "a new claim, though the first began 550 ms ago";
    EXPECT_EQ(c.since_us(), 2'000'000u);
    EXPECT_FALSE(c.claim(2'374'999, 1'650'000, kConfirm));
    EXPECT_TRUE(c.claim(2'375'000, 1'650'000, kConfirm));
}

// The old process heard at the very time the claim began (one batch of datagrams) has not
// answered it; only a datagram after the claim does.
TEST(RestartClaim, HeardAtTheClaimsOwnTimeIsNoAnswer) {
    RestartClaim c;
    EXPECT_FALSE(c.claim(500'000, 500'000, kConfirm));
    EXPECT_TRUE(c.stands(500'000));
    EXPECT_TRUE(c.claim(875'000, 500'000, kConfirm));
    EXPECT_FALSE(c.stands(500'001));
}

TEST(RestartClaim, ClearForgetsTheClaim) {
    RestartClaim c;
    EXPECT_FALSE(c.claim(100, 0, kConfirm));
    c.clear();
    EXPECT_FALSE(c.stands(0));
    EXPECT_FALSE(c.claim(kConfirm + 100, 0, kConfirm)) << "a claim begun before clear() is gone";
}

// Without a window (0) a claim counts at its first hello (the rule before the window).
TEST(RestartClaim, NoWindowCountsAtOnce) {
    RestartClaim c;
    EXPECT_TRUE(c.claim(100, 0, 0));
}

}  // namespace
}  // namespace lockroll::rollback
