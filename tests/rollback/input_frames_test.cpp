// unwrap_input (rollback/input_frames.h) on its own: an input message's frames unwrapped against
// what the session holds, and each way a message is refused before anything of it is applied.
#include "rollback/input_frames.h"

#include <gtest/gtest.h>

#include <string>

namespace lockroll::rollback {
namespace {

InputReferences refs() {
    return {.from_player = true, .takes_ack = true, .our_count = 70'000, .its_count = 70'010, .frame = 70'005,
            .newest_checksum = 69'990, .players = 3};
}

InputMessage message() {
    InputMessage m;
    m.ack = static_cast<std::uint16_t>(69'990);
    m.frame_count = 1;
    m.first_frame = static_cast<std::uint16_t>(70'010);
    m.has_time_sync = true;
    m.sender_frame = static_cast<std::uint16_t>(70'007);
    m.checksum_count = 1;
    m.checksum_frames[0] = static_cast<std::uint16_t>(69'960);
    return m;
}

std::string why(const InputMessage& m, const InputReferences& r) {
    InputFrames f;
    const char* e = unwrap_input(m, r, f);
    return e ? e : "";
}

TEST(InputFrames, UnwrapsEveryFrameNearWhatTheSessionHolds) {
    InputFrames f;
    ASSERT_EQ(unwrap_input(message(), refs(), f), nullptr);
    EXPECT_EQ(f.ack, 69'990u);
    EXPECT_EQ(f.first, 70'010u);
    EXPECT_EQ(f.sender_frame, 70'007u);
    EXPECT_EQ(f.checksum_frames[0], 69'960u);
    InputReferences spectator = refs();
    spectator.takes_ack = false;
    InputMessage m = message();
    m.frame_count = 0;
    ASSERT_EQ(unwrap_input(m, spectator, f), nullptr);
    EXPECT_FALSE(f.ack);
    EXPECT_FALSE(f.first);
}

TEST(InputFrames, RefusesWhatCannotBeMeant) {
    InputMessage ahead = message();
    ahead.ack = static_cast<std::uint16_t>(70'001);
    EXPECT_EQ(why(ahead, refs()), "input message: acknowledges inputs never sent");
    InputReferences from_spectator = refs();
    from_spectator.from_player = false;
    from_spectator.takes_ack = false;
    EXPECT_EQ(why(message(), from_spectator), "input message: a spectator sent inputs");
    InputReferences early = refs();
    early.our_count = 10;
    InputMessage negative = message();
    negative.ack = 65'000;  // closest to 10 is below frame 0
    EXPECT_EQ(why(negative, early), "input message: ack frame out of range");
    InputMessage slot = message();
    slot.slots.push_back({3, SlotState::Running, 0, 0});
    EXPECT_EQ(why(slot, refs()), "input message: slot entry out of range");
    InputMessage block = message();
    block.blocks.emplace_back();
    block.blocks.back().slot = 7;
    EXPECT_EQ(why(block, refs()), "input message: stream block slot out of range");
}

}  // namespace
}  // namespace lockroll::rollback
