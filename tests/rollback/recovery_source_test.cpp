// recovery_source (rollback/recovery_source.h) on its own: the majority's state is reloaded by
// the odd ones, a tie keeps the lowest (or highest) slot's group.
#include "rollback/recovery_source.h"

#include <gtest/gtest.h>

#include <vector>

namespace lockroll::rollback {
namespace {

using Answers = std::vector<std::pair<PlayerId, std::uint64_t>>;

TEST(RecoverySource, TheMinorityReloadsFromTheMajoritysLowestSlot) {
    const Answers others{{0, 7}, {2, 7}, {3, 7}};
    EXPECT_EQ(recovery_source(1, 9, others, DesyncKeep::LowestSlot), PlayerId{0});
    const Answers with_odd{{1, 9}, {2, 7}, {3, 7}};
    EXPECT_EQ(recovery_source(0, 7, with_odd, DesyncKeep::LowestSlot), std::nullopt) << "in the majority: stays";
}

TEST(RecoverySource, ATieKeepsTheGroupOfTheLowestOrHighestSlot) {
    const Answers other{{1, 5}};
    EXPECT_EQ(recovery_source(0, 4, other, DesyncKeep::LowestSlot), std::nullopt);
    EXPECT_EQ(recovery_source(0, 4, other, DesyncKeep::HighestSlot), PlayerId{1});
    const Answers lower{{0, 4}};
    EXPECT_EQ(recovery_source(1, 5, lower, DesyncKeep::LowestSlot), PlayerId{0});
    EXPECT_EQ(recovery_source(1, 5, lower, DesyncKeep::HighestSlot), std::nullopt);
}

TEST(RecoverySource, OnlyTheLow32BitsCount) {
    const Answers other{{1, 0x1'0000'0005}, {2, 0x2'0000'0005}};
    EXPECT_EQ(recovery_source(0, 5, other, DesyncKeep::LowestSlot), std::nullopt) << "all three agree";
}

}  // namespace
}  // namespace lockroll::rollback
