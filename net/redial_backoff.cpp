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

void RedialBackoff::heard(std::size_t id) {
    if (id < peers_.size()) peers_[id] = Peer{};
}

std::uint64_t RedialBackoff::interval_us(std::size_t id) const {
    return id < peers_.size() ? peers_[id].interval_us : kFirstUs;
}

}  // namespace lockroll::net
