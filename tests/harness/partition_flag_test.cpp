// --partition values to schedules: the syntax, frames to microseconds, and every refusal naming
// the flag and the offending part.
#include "harness/partition_flag.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "harness/match/cli_error.h"

namespace lockroll::harness {
namespace {

using transport::PartitionCut;

TEST(PartitionFlag, TheIssueExampleIsTwoSetsFromFrame200To800) {
    const auto s = parse_partitions({"0,1,2,3/4,5,6,7@200-800"}, 8, 60);
    ASSERT_EQ(s.cuts().size(), 1u);
    const PartitionCut& c = s.cuts()[0];
    EXPECT_EQ(c.sets, (std::vector<std::vector<transport::PeerId>>{{0, 1, 2, 3}, {4, 5, 6, 7}}));
    EXPECT_EQ(c.from_us, 200u * 1'000'000 / 60);  // 3,333,333
    EXPECT_EQ(c.until_us, 800u * 1'000'000 / 60);  // 13,333,333
    EXPECT_EQ(c.from_us, 3'333'333u);
    EXPECT_TRUE(s.is_cut(3, 4, c.from_us));
    EXPECT_FALSE(s.is_cut(3, 4, c.until_us));
}

TEST(PartitionFlag, SeveralCutsBySemicolonOrByRepeatingTheFlag) {
    const auto one = parse_partitions({"0/1/2@60-120;0,1/2@300-360"}, 3, 60);
    const auto two = parse_partitions({"0/1/2@60-120", "0,1/2@300-360"}, 3, 60);
    EXPECT_EQ(one, two);
    ASSERT_EQ(one.cuts().size(), 2u);
    EXPECT_EQ(one.cuts()[0].sets.size(), 3u);
    EXPECT_EQ(one.cuts()[1].from_us, 5'000'000u);
    EXPECT_EQ(one.cuts()[1].until_us, 6'000'000u);
    EXPECT_TRUE(parse_partitions({}, 4, 60).empty());
}

TEST(PartitionFlag, FramesFollowTheTickRate) {
    const auto s = parse_partitions({"0/1@30-90"}, 2, 30);
    EXPECT_EQ(s.cuts()[0].from_us, 1'000'000u);
    EXPECT_EQ(s.cuts()[0].until_us, 3'000'000u);
    const auto at_zero = parse_partitions({"1/0@0-1"}, 2, 1000);
    EXPECT_EQ(at_zero.cuts()[0].from_us, 0u);
    EXPECT_EQ(at_zero.cuts()[0].until_us, 1'000u);
}

// Each bad value: exit-2 error (UsageError) naming --partition, the value and the part.
TEST(PartitionFlag, RefusesBadValuesNamingTheFlagAndThePart) {
    const std::pair<const char*, const char*> cases[] = {
        {"", "--partition '': syntax: expected SETS@FROM-UNTIL"},
        {"0,1/2,3", "--partition '0,1/2,3': syntax: expected SETS@FROM-UNTIL"},
        {"0/1@5@9", "syntax"},
        {"0/1@200", "frames '200': expected FROM-UNTIL"},
        {"0/1@a-9", "frames 'a-9': expected FROM-UNTIL"},
        {"0/1@-5-9", "frames '-5-9'"},
        {"0/1@5-99999999999", "frames '5-99999999999'"},
        {"0/1@800-200", "--partition '0/1@800-200': frames '800-200': FROM must be below UNTIL"},
        {"0/1@200-200", "frames '200-200': FROM must be below UNTIL"},
        {"0,1@1-5", "sets '0,1': expected two or more slot sets"},
        {"0//1@1-5", "set '': expected slot numbers"},
        {"0,/1@1-5", "set '0,': expected slot numbers"},
        {"0, 1/2@1-5", "set '0, 1': expected slot numbers"},
        {"x/1@1-5", "set 'x'"},
        {"0,1/1,2@1-5", "slot 1: named twice (the sets must not overlap)"},
        {"0,0/1@1-5", "slot 0: named twice"},
        {"0/4@1-5", "--partition '0/4@1-5': slot 4: not in 0..3 (--players 4)"},
        {"0/1@1-5;0/1@9-3", "--partition '0/1@1-5;0/1@9-3': cut 2 '0/1@9-3': frames '9-3': FROM must be below UNTIL"},
        {"0/1@1-5;", "cut 2 '': syntax"},
    };
    for (const auto& [value, want] : cases) {
        try {
            parse_partitions({value}, 4, 60);
            ADD_FAILURE() << "accepted '" << value << "'";
        } catch (const UsageError& e) {
            EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << "'" << value << "': " << e.what();
            EXPECT_EQ(std::string(e.what()).rfind("--partition '", 0), 0u) << e.what();
        }
    }
}

}  // namespace
}  // namespace lockroll::harness
