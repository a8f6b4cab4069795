#include "rollback/peer_link.h"

#include <algorithm>

namespace lockroll::rollback {

bool PeerLink::note_malformed(const char* why) {
    last_error_ = why;
    ++malformed_;
    if (!error_ && malformed_ >= static_cast<std::uint64_t>(max_bad_packets_)) {
        error_ = true;
        return true;
    }
    return false;
}

PeerLink::Stamps PeerLink::outgoing_stamps(std::uint64_t now_us) const {
    Stamps s;
    s.stamp = static_cast<std::uint16_t>(now_us / 100);
    if (s.stamp == kNoEcho) s.stamp = 0;
    if (has_stamp) {
        s.echo = stamp;
        s.hold = static_cast<std::uint16_t>(std::min<std::uint64_t>((now_us - stamp_at_us) / 100, kNoEcho - 1));
    }
    return s;
}

void PeerLink::take_stamps(std::uint16_t their_stamp, std::uint16_t echo, std::uint16_t hold, std::uint64_t now_us) {
    if (echo != kNoEcho && hold != kNoEcho) {
        const auto now_units = static_cast<std::uint16_t>(now_us / 100);
        const auto elapsed = static_cast<std::uint16_t>(now_units - echo);
        if (elapsed >= hold && elapsed - hold < 30000) add_rtt_sample(static_cast<std::uint64_t>(elapsed - hold) * 100);
    }
    has_stamp = true;
    stamp = their_stamp;
    stamp_at_us = now_us;
}

}  // namespace lockroll::rollback
