#include "rollback/playing_alone.h"

#include <algorithm>

namespace lockroll::rollback {

std::vector<PlayerId> running_voters(const Session& s) {
    std::vector<PlayerId> out;
    for (int p = 0; p < s.config().players; ++p) {
        const auto id = static_cast<PlayerId>(p);
        if (s.host_of(id) == id && s.slot_state(id) == SlotState::Running) out.push_back(id);
    }
    return out;
}

void AloneSince::saw(const SessionEvent& e, int players) {
    if (e.kind == SessionEvent::Kind::Disconnected && e.peer < static_cast<PlayerId>(players)) last_drop_ = e.frame;
}

void AloneSince::settle(std::span<const PlayerId> voters, PlayerId local) {
    const bool others = std::any_of(voters.begin(), voters.end(), [local](PlayerId v) { return v != local; });
    const bool alone = !others && voters.size() == 1;
    if (others) since_.reset();
    else if (alone && !since_ && last_drop_) since_ = last_drop_;
    last_drop_.reset();
}

}  // namespace lockroll::rollback
