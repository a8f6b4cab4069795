// The one input-delay policy (rollback/input_delay.h): lockstep covers the reach in whole frames
// plus one, rollback half of that rounded up, adaptive never below lockstep - window + 1.
#include "rollback/input_delay.h"

#include <gtest/gtest.h>

using namespace lockroll::rollback;

TEST(InputDelay, LockstepCoversTheReachPlusAFrame) {
    EXPECT_EQ(lockstep_input_delay(0, 60), 1);
    EXPECT_EQ(lockstep_input_delay(1, 60), 2);
    EXPECT_EQ(lockstep_input_delay(35500, 60), 4);  // 2.13 frames -> 3, +1
    // Exact at frame boundaries: 50 ms at 60 Hz is exactly 3 frames (a truncated tick of 16,666 us
    // made it 5).
    EXPECT_EQ(lockstep_input_delay(50000, 60), 4);
    EXPECT_EQ(lockstep_input_delay(50001, 60), 5);
    EXPECT_EQ(lockstep_input_delay(10000, 100), 2);
    EXPECT_EQ(lockstep_input_delay(10001, 100), 3);
}

TEST(InputDelay, RollbackTakesHalfRoundedUp) {
    EXPECT_EQ(rollback_input_delay(0, 60), 1);
    EXPECT_EQ(rollback_input_delay(35500, 60), 2);  // lockstep 4
    EXPECT_EQ(rollback_input_delay(50001, 60), 3);  // lockstep 5
    EXPECT_EQ(auto_input_delay(0, 35500, 60), 4);
    EXPECT_EQ(auto_input_delay(8, 35500, 60), 2);
}

TEST(InputDelay, CappedForAnyReach) {
    EXPECT_EQ(lockstep_input_delay(5000000, 60), kMaxInputDelay);
    EXPECT_EQ(lockstep_input_delay(UINT64_MAX, 10000), kMaxInputDelay);
    EXPECT_EQ(rollback_input_delay(UINT64_MAX, 60), (kMaxInputDelay + 1) / 2);
    EXPECT_EQ(lockstep_input_delay(983333, 60), 60);  // 59 frames + 1
    EXPECT_EQ(lockstep_input_delay(966666, 60), 59);
}

TEST(InputDelay, AdaptiveRollbackKeepsDelayPlusWindowAboveLockstep) {
    for (std::uint64_t reach : {0ull, 15000ull, 60000ull, 150000ull, 300000ull, 900000ull})
        for (int window : {1, 2, 4, 8}) {
            const int lockstep = adaptive_input_delay(0, reach, 60);
            const int rollback = adaptive_input_delay(window, reach, 60);
            EXPECT_EQ(lockstep, lockstep_input_delay(reach, 60));
            EXPECT_GT(rollback + window, lockstep) << reach << " " << window;
            EXPECT_LE(rollback, lockstep);
            EXPECT_GE(rollback, rollback_input_delay(reach, 60));
        }
    // 300 ms reach: lockstep 19, half 10; window 2 forces 18, window 8 forces 12, window 16 leaves 10.
    EXPECT_EQ(adaptive_input_delay(2, 300000, 60), 18);
    EXPECT_EQ(adaptive_input_delay(8, 300000, 60), 12);
    EXPECT_EQ(adaptive_input_delay(16, 300000, 60), 10);
}
