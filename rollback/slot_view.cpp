#include "rollback/slot_view.h"

#include <algorithm>

namespace lockroll::rollback {

void SlotView::dropped(std::uint64_t now_us, std::uint64_t disconnect_us) {
    if (lapsed && !orphaned) {  // a handoff that lapsed: the next one waits (watch_handoff)
        lapses = std::min(lapses + 1, 3);
        next_handoff_us = now_us + (disconnect_us << lapses);
    }
    new_epoch();
}

SlotView::Watch SlotView::watch_handoff(bool running, const InputQueue& q, std::uint32_t frame, std::uint64_t now_us,
                                        std::uint64_t disconnect_us) {
    const bool started = stream_started(q);
    if (running && started) {
        lapses = 0;  // its own stream started: the join succeeded
        pending_since_us = 0;
        if (!lapse_vote) return Watch::Nothing;
        lapse_vote = false;  // it plays: the vote from its lapse is withdrawn
        return Watch::Started;
    }
    // Pending: running, its newest input the owner's neutral one, and needed (we are at or past
    // its stream's end, predicting or stalled on it): the stall the contract bounds starts here.
    if (!running || started || q.confirmed_count() == 0 || q.confirmed_count() > frame) {
        pending_since_us = 0;
        return Watch::Nothing;
    }
    if (pending_since_us == 0) pending_since_us = now_us;
    if (lapsed || disconnect_us == 0 || (!orphaned && now_us - pending_since_us < disconnect_us)) return Watch::Nothing;
    lapsed = true;
    lapse_vote = true;
    return Watch::Lapsed;
}

}  // namespace lockroll::rollback
