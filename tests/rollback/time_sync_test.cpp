// TimeSync on its own (rollback/time_sync.h): frame advantage averaged over a sliding window,
// a wait recommended only from a full window and a lead of at least min_frames, both sides of a
// pair seen together, and what claims far outside the protocol's range do to the arithmetic.
// Values are x100 fixed point and truncate toward zero (integer division).
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "rollback/time_sync.h"

namespace lockroll::rollback {
namespace {

// Feeds `n` copies of one sample.
void feed(TimeSync& t, int n, std::int32_t local, std::int32_t remote) {
    for (int i = 0; i < n; ++i) t.add_sample(local, remote);
}

TEST(TimeSync, NoDataNoRecommendation) {
    TimeSync t(8);
    EXPECT_EQ(t.samples(), 0);
    EXPECT_FALSE(t.full());
    EXPECT_EQ(t.frames_ahead_x100(), 0);
    EXPECT_EQ(t.local_advantage_x100(), 0);
    for (const int min : {0, 1, 2, 100}) EXPECT_EQ(t.recommended_wait(min), 0) << min;
}

TEST(TimeSync, AveragesOverTheSlidingWindow) {
    TimeSync t(4);
    t.add_sample(-2, 2);
    t.add_sample(-4, 4);
    // A partial window averages what it has: (2 + 4 + 2 + 4) / 2 / 2 samples = 3 frames.
    EXPECT_EQ(t.samples(), 2);
    EXPECT_EQ(t.frames_ahead_x100(), 300);
    EXPECT_EQ(t.local_advantage_x100(), -300);
    t.add_sample(-6, 6);
    t.add_sample(-8, 8);
    EXPECT_TRUE(t.full());
    EXPECT_EQ(t.frames_ahead_x100(), 500);
    EXPECT_EQ(t.local_advantage_x100(), -500);
    // The fifth sample pushes out the first: (4 + 6 + 8 + 0) * 2 / 2 / 4 = 4.5 frames.
    t.add_sample(0, 0);
    EXPECT_EQ(t.samples(), 4);
    EXPECT_EQ(t.frames_ahead_x100(), 450);
    EXPECT_EQ(t.local_advantage_x100(), -450);
    // Four more: nothing of the old samples is left.
    feed(t, 4, 1, 1);
    EXPECT_EQ(t.frames_ahead_x100(), 0);
    EXPECT_EQ(t.local_advantage_x100(), 100);
}

TEST(TimeSync, FractionsTruncateTowardZero) {
    TimeSync t(4);
    feed(t, 3, 0, 0);
    t.add_sample(0, 1);  // half a frame over 4 samples: 12.5
    EXPECT_EQ(t.frames_ahead_x100(), 12);
    TimeSync u(4);
    feed(u, 3, 0, 0);
    u.add_sample(0, -1);
    EXPECT_EQ(u.frames_ahead_x100(), -12);
    TimeSync v(3);
    feed(v, 2, 0, 0);
    v.add_sample(1, 0);  // 100 / 3
    EXPECT_EQ(v.local_advantage_x100(), 33);
}

TEST(TimeSync, RecommendsOnlyFromAFullWindowAndAtLeastMinFramesAhead) {
    // Window 4: a summed gap (remote - local) of D gives frames_ahead_x100 = D * 100 / 8.
    const auto with_gap = [](int gap) {  // D = 2 * gap, spread over the window
        TimeSync t(4);
        feed(t, 4, 0, 0);
        t.add_sample(-gap, gap);
        return t;
    };
    struct Case {
        int gap;
        std::int32_t ahead_x100;
        int min_frames, wait;
    };
    for (const Case c : {Case{8, 200, 2, 2},    // exactly min is enough ("at least")
                         Case{8, 200, 3, 0},
                         Case{7, 175, 2, 0},    // rounds to 2, but the lead is below min
                         Case{7, 175, 1, 2},    // rounded to nearest
                         Case{10, 250, 1, 3},   // a half rounds up
                         Case{9, 225, 1, 2}}) {  // below a half rounds down
        const TimeSync t = with_gap(c.gap);
        EXPECT_EQ(t.frames_ahead_x100(), c.ahead_x100) << "gap " << c.gap;
        EXPECT_EQ(t.recommended_wait(c.min_frames), c.wait) << "gap " << c.gap << ", min " << c.min_frames;
    }
    // Not full: nothing, however far ahead.
    TimeSync partial(4);
    feed(partial, 3, -50, 50);
    EXPECT_EQ(partial.frames_ahead_x100(), 5000);
    EXPECT_EQ(partial.recommended_wait(1), 0);
    partial.add_sample(-50, 50);
    EXPECT_EQ(partial.recommended_wait(1), 50);
    // Behind: never a wait.
    TimeSync behind(4);
    feed(behind, 4, 6, -6);
    EXPECT_EQ(behind.frames_ahead_x100(), -600);
    EXPECT_EQ(behind.recommended_wait(1), 0);
}

// Both ends of one pair: k frames apart, each side's estimates are the other's negated. Only
// the one ahead waits, and latency misjudged by both sides cancels out.
TEST(TimeSync, SymmetricPeersAgreeOnWhoWaits) {
    for (int k = 0; k <= 12; ++k) {
        for (const int bias : {0, 3, -2}) {  // one-way latency misestimate, same on both sides
            SCOPED_TRACE(testing::Message() << "k " << k << ", bias " << bias);
            TimeSync ahead(6), behind(6);
            feed(ahead, 6, -k + bias, k + bias);
            feed(behind, 6, k + bias, -k + bias);
            EXPECT_EQ(ahead.frames_ahead_x100(), 100 * k);
            EXPECT_EQ(behind.frames_ahead_x100(), -100 * k);
            EXPECT_EQ(ahead.recommended_wait(2), k >= 2 ? k : 0);
            EXPECT_EQ(behind.recommended_wait(2), 0);
        }
    }
    // Level: neither waits, even with min_frames 0.
    TimeSync a(4), b(4);
    feed(a, 4, 1, 1);
    feed(b, 4, 1, 1);
    EXPECT_EQ(a.recommended_wait(0), 0);
    EXPECT_EQ(b.recommended_wait(0), 0);
}

TEST(TimeSync, ClearStartsAFreshWindow) {
    TimeSync t(4);
    feed(t, 6, -10, 10);
    ASSERT_EQ(t.recommended_wait(1), 10);
    t.clear();
    EXPECT_EQ(t.samples(), 0);
    EXPECT_FALSE(t.full());
    EXPECT_EQ(t.frames_ahead_x100(), 0);
    EXPECT_EQ(t.recommended_wait(1), 0);
    // Refilled, and then slid: none of the cleared samples leak back into the sums.
    feed(t, 4, -2, 2);
    EXPECT_EQ(t.frames_ahead_x100(), 200);
    feed(t, 3, -4, 4);
    EXPECT_EQ(t.frames_ahead_x100(), 350);  // (2 + 3 * 4) * 2 / 8
    EXPECT_EQ(t.recommended_wait(1), 4);
}

TEST(TimeSync, WindowBelowOneIsOne) {
    for (const int w : {0, -3}) {
        TimeSync t(w);
        EXPECT_FALSE(t.full());
        t.add_sample(-3, 3);
        EXPECT_TRUE(t.full());
        EXPECT_EQ(t.recommended_wait(1), 3);
        t.add_sample(0, 0);  // replaces the only sample
        EXPECT_EQ(t.samples(), 1);
        EXPECT_EQ(t.recommended_wait(1), 0);
    }
}

// TimeSync has no cap of its own: the wait follows the claim. The bound lives in the caller:
// Session clamps every sample, local and remote, to input_delay + window + 2 * min + 2 frames
// before add_sample (session.cpp; end to end in Lifecycle.ForgedTimeSyncClaimIsBounded), and
// the wire carries an int8. A core shared by both sessions must keep that clamp.
TEST(TimeSync, WaitFollowsTheClaimWithinTheWireRange) {
    struct Claim {
        std::int32_t local, remote, ahead_x100;
        int wait;
    };
    for (const Claim c : {Claim{0, 127, 6350, 64},         // the largest an input message carries
                          Claim{-128, 127, 12750, 128},    // both ends of the int8 range
                          Claim{0, 1'000'000, 50'000'000, 500'000}}) {  // far outside it, still exact
        TimeSync t(8);
        feed(t, 8, c.local, c.remote);
        EXPECT_EQ(t.frames_ahead_x100(), c.ahead_x100) << c.local << ", " << c.remote;
        EXPECT_EQ(t.recommended_wait(1), c.wait) << c.local << ", " << c.remote;
    }
}

// A peer's claim is any int32. Before the fix the x100 averages were cast to int32 without
// saturating and recommended_wait() added 50 to a value near INT32_MAX (undefined): a claim of
// INT32_MAX frames ahead read as half a frame behind (-50), 100,000,000 as 7,050,327 frames and
// 42,949,672 as a wait of -21,474,836. Session clamps its samples anyway (see above).
TEST(TimeSync, ExtremeClaimsSaturateInsteadOfWrapping) {
    constexpr std::int32_t kMax = std::numeric_limits<std::int32_t>::max();
    constexpr std::int32_t kMin = std::numeric_limits<std::int32_t>::min();
    TimeSync extreme(4);
    feed(extreme, 4, kMin, kMax);
    EXPECT_GT(extreme.frames_ahead_x100(), 0);  // far ahead, not behind
    EXPECT_LT(extreme.local_advantage_x100(), 0);
    EXPECT_GE(extreme.recommended_wait(1), 21'000'000);
    // A larger claim never recommends a shorter (or negative) wait.
    int previous = 0;
    for (const std::int32_t claim : {1'000'000, 42'949'671, 42'949'672, 100'000'000, kMax}) {
        TimeSync t(4);
        feed(t, 4, 0, claim);
        const int wait = t.recommended_wait(1);
        EXPECT_GE(wait, previous) << "claim " << claim;
        EXPECT_GT(t.frames_ahead_x100(), 0) << "claim " << claim;
        previous = wait;
    }
}

}  // namespace
}  // namespace lockroll::rollback
