// A peer's input message names every frame by its low 16 bits (rollback/protocol.h). Before a
// P2P session applies anything of it, every frame is unwrapped against what the session holds
// and checked, so a bad message changes nothing (a datagram is a claim): its ack of our stream,
// the first frame of its own inputs, its frame (time sync), its checksum frames, and the slots
// its table and blocks name.
//
// Contract: unwrap_input returns nullptr with every frame in `out`, or why the message is
// malformed (the session counts it against the sender). Pure: no session, no time.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "rollback/protocol.h"

namespace lockroll::rollback {

// What the message's frames are unwrapped against.
struct InputReferences {
    bool from_player = false;      // the sender plays a slot (a spectator sends no inputs)
    bool takes_ack = false;        // from a player, and this session plays: it acks our stream
    std::uint32_t our_count = 0;   // our stream's confirmed count (an ack beyond it acks inputs never sent)
    std::uint32_t its_count = 0;   // the sender's stream's confirmed count here (from_player)
    std::uint32_t frame = 0;       // our frame: the sender's is near it
    std::uint32_t newest_checksum = 0;  // our newest confirmed checksum's frame
    int players = 0;
};

struct InputFrames {
    std::optional<std::uint32_t> ack;           // takes_ack
    std::optional<std::uint32_t> first;         // frame_count > 0
    std::optional<std::uint32_t> sender_frame;  // has_time_sync
    std::array<std::uint32_t, kMaxChecksumsPerMessage> checksum_frames{};
};

const char* unwrap_input(const InputMessage& m, const InputReferences& r, InputFrames& out);

}  // namespace lockroll::rollback
