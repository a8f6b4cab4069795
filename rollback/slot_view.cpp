#include "rollback/slot_view.h"

#include <algorithm>

namespace lockroll::rollback {

void SlotView::dropped(std::uint64_t now_us, std::uint64_t disconnect_us) {
    if (lapsed) {  // a handoff that lapsed: the next one waits (watch_handoff)
        lapses = std::min(lapses + 1, 3);
        next_handoff_us = now_us + (disconnect_us << lapses);
    }
    new_epoch();
}

bool SlotView::watch_handoff(bool running, const InputQueue& q, std::uint32_t frame, std::uint64_t now_us,
                             std::uint64_t disconnect_us) {
    const bool started = stream_started(q);
    if (running && started) lapses = 0;  // its own stream started: the join succeeded
    // Pending: running, its newest input the owner's neutral one, and needed (we are at or past
    // its stream's end, predicting or stalled on it): the stall the contract bounds starts here.
    if (!running || started || q.confirmed_count() == 0 || q.confirmed_count() > frame) {
        pending_since_us = 0;
        return false;
    }
    if (pending_since_us == 0) pending_since_us = now_us;
    if (lapsed || disconnect_us == 0 || now_us - pending_since_us < disconnect_us) return false;
    lapsed = true;
    return true;
}

}  // namespace lockroll::rollback
