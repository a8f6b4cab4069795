#include "net/redial_backoff.h"

#include <algorithm>

namespace lockroll::net {

bool RedialBackoff::due(std::size_t id, std::uint64_t now_us) const {
    return id < peers_.size() && now_us >= peers_[id].next_us;
}

void RedialBackoff::dialed(std::size_t id, std::uint64_t now_us) {
    if (id >= peers_.size()) return;
    Peer& p = peers_[id];
    p.next_us = now_us + p.interval_us;
    p.interval_us = std::min(p.interval_us * 2, kCapUs);
}

bool RedialBackoff::try_dial(std::size_t id, std::uint64_t now_us, const std::function<bool()>& connect) {
    if (!due(id, now_us)) return false;
    if (connect()) {
        dialed(id, now_us);
        return true;
    }
    peers_[id].next_us = now_us + kRecheckUs;  // refused, no attempt: not charged, looked at again soon
    return false;
}

void RedialBackoff::heard(std::size_t id) {
    if (id < peers_.size()) peers_[id] = Peer{};
}

std::uint64_t RedialBackoff::interval_us(std::size_t id) const {
    return id < peers_.size() ? peers_[id].interval_us : kFirstUs;
}

}  // namespace lockroll::net
