// FrameHistory: oldest-first records in a ring that grows by doubling to its limit, then drops
// the oldest.
#include <gtest/gtest.h>

#include "server/frame_history.h"

namespace lockroll::server {
namespace {

TEST(FrameHistory, KeepsTheNewestRecordsInOrderAcrossGrowthAndWrap) {
    FrameHistory h(3, 100);
    for (int i = 0; i < 250; ++i) {
        auto r = h.push();
        for (auto b : r) EXPECT_EQ(b, 0);  // a fresh record is zeroed
        r[0] = static_cast<std::uint8_t>(i);
        r[2] = static_cast<std::uint8_t>(i * 3);
        if (i < 100) {
            EXPECT_EQ(h.size(), static_cast<std::size_t>(i + 1));
        }
    }
    ASSERT_EQ(h.size(), 100u);
    for (std::size_t k = 0; k < 100; ++k) {
        EXPECT_EQ(h.at(k)[0], static_cast<std::uint8_t>(150 + k));
        EXPECT_EQ(h.at(k)[2], static_cast<std::uint8_t>((150 + k) * 3));
    }
    EXPECT_LE(h.bytes_reserved(), 100u * 3u);  // never beyond the limit
}

TEST(FrameHistory, ShortMatchesAllocateLittle) {
    FrameHistory h(8, 36000);  // ten minutes at 60 Hz, 2 players with 3-byte inputs
    for (int i = 0; i < 10; ++i) h.push();
    EXPECT_LE(h.bytes_reserved(), 64u * 8u);
}

}  // namespace
}  // namespace lockroll::server
