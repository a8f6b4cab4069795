#include "rollback/input_frames.h"

namespace lockroll::rollback {

const char* unwrap_input(const InputMessage& m, const InputReferences& r, InputFrames& out) {
    out = InputFrames{};
    if (r.takes_ack) {
        out.ack = unwrap_frame(m.ack, r.our_count);
        if (!out.ack) return "input message: ack frame out of range";
        if (*out.ack > r.our_count) return "input message: acknowledges inputs never sent";
    }
    if (m.frame_count > 0) {
        if (!r.from_player) return "input message: a spectator sent inputs";
        out.first = unwrap_frame(m.first_frame, r.its_count);
        if (!out.first) return "input message: first frame out of range";
    }
    if (m.has_time_sync) {
        out.sender_frame = unwrap_frame(m.sender_frame, r.frame);
        if (!out.sender_frame) return "input message: sender frame out of range";
    }
    for (int i = 0; i < m.checksum_count; ++i) {
        const auto f = unwrap_frame(m.checksum_frames[i], r.newest_checksum);
        if (!f) return "input message: checksum frame out of range";
        out.checksum_frames[static_cast<std::size_t>(i)] = *f;
    }
    for (const SlotEntry& e : m.slots)
        if (e.slot >= r.players) return "input message: slot entry out of range";
    for (const StreamBlock& b : m.blocks)
        if (b.slot >= r.players) return "input message: stream block slot out of range";
    return nullptr;
}

}  // namespace lockroll::rollback
