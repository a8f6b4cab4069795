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

bool PeerLink::hear(std::uint64_t now_us) {
    const bool resumed = interrupted;
    interrupted = false;
    mark_heard(now_us);
    return resumed;
}

PeerLink::Silence PeerLink::check_silence(std::uint64_t now_us, std::uint64_t interrupt_us, std::uint64_t disconnect_us) {
    Silence s;
    if (!heard) return s;
    s.silent_us = now_us > last_heard_us ? now_us - last_heard_us : 0;
    if (!interrupted && s.silent_us >= interrupt_us) {
        interrupted = true;
        s.interrupted_now = true;
    }
    s.timed_out = disconnect_us != 0 && s.silent_us >= disconnect_us;
    return s;
}

bool PeerLink::hello_due(std::uint64_t now_us, std::uint64_t resend_us) {
    if (hello_sent && now_us < last_hello_us + resend_us) return false;
    hello_sent = true;
    last_hello_us = now_us;
    return true;
}

bool PeerLink::sync_welcome(std::uint64_t echo_us, bool running, std::uint64_t now_us) {
    if (echo_us <= now_us) {
        const std::uint64_t rtt = now_us - echo_us;
        add_rtt_sample(rtt);
        max_sync_rtt_us = std::max(max_sync_rtt_us, rtt);
    }
    const bool first = !welcomed;
    welcomed = true;
    mark_heard(now_us);
    if (roundtrips < 1000) ++roundtrips;
    has_remote_frame = has_remote_frame || running;
    return first;
}

void PeerLink::late_welcome(std::uint8_t epoch, std::uint64_t echo_us, std::uint64_t now_us) {
    if (echo_us <= now_us) add_rtt_sample(now_us - echo_us);
    welcomed = true;
    welcomed_epoch = epoch;
    role = Role::Player;
    has_remote_frame = true;
    mark_heard(now_us);
    interrupted = false;
}

void PeerLink::accept_hello(Role r, std::uint64_t process, std::optional<std::uint8_t> epoch, std::uint64_t now_us) {
    welcomed = true;
    if (epoch) welcomed_epoch = *epoch;
    incarnation = process;
    role = r;
    if (!heard) mark_heard(now_us);
}

std::int64_t PeerLink::estimated_frame(std::uint64_t now_us, std::uint64_t interrupt_us, int tick_rate) const {
    const std::uint64_t silent = now_us >= remote_frame_time_us ? now_us - remote_frame_time_us : 0;
    const std::uint64_t elapsed = std::min(silent, interrupt_us) + rtt_us() / 2;
    return std::int64_t{remote_frame} + static_cast<std::int64_t>(elapsed * static_cast<std::uint64_t>(tick_rate) / 1000000);
}

bool PeerLink::table_due(const std::vector<std::uint16_t>& entries, std::uint64_t now_us, std::uint64_t refresh_us) const {
    if (entries != table_entries_sent_) return true;
    if (table_copies_ < table_copies_wanted_) {
        // After k copies (k >= 1), the next goes 2^(k-1) messages after the change.
        const std::uint64_t gap = std::uint64_t{1} << std::clamp(table_copies_ - 1, 0, 62);
        if (messages_sent >= table_change_message_ + gap) return true;
    }
    return table_changed_ && refresh_us != 0 && now_us >= table_sent_us_ + refresh_us;
}

void PeerLink::table_sent(const std::vector<std::uint16_t>& entries, std::uint64_t now_us, int copies) {
    if (entries != table_entries_sent_) {
        table_entries_sent_ = entries;
        table_copies_ = 0;
        table_copies_wanted_ = copies;
        table_change_message_ = messages_sent;
        table_changed_ = true;
    }
    ++table_copies_;
    table_sent_us_ = now_us;
}

void PeerLink::table_assumed(const std::vector<std::uint16_t>& entries, std::uint64_t now_us) {
    table_entries_sent_ = entries;
    table_copies_ = 0;
    table_copies_wanted_ = 0;
    table_changed_ = false;
    table_sent_us_ = now_us;
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

NetworkStats network_stats(const PeerLink& link, const PeerStats& traffic, const OverlayClock& at,
                           std::optional<std::uint32_t> sent) {
    NetworkStats n;
    n.ping_us = link.rtt_us();
    n.jitter_us = link.rtt_var_us();
    if (at.seconds > 0) {
        n.kbps_sent = static_cast<double>(traffic.bytes_sent) * 8 / 1000 / at.seconds;
        n.kbps_received = static_cast<double>(traffic.bytes_received) * 8 / 1000 / at.seconds;
    }
    if (link.has_remote_frame)
        n.frames_behind = static_cast<std::int32_t>(std::int64_t{at.frame} - link.estimated_frame(at.now_us, at.interrupt_us, at.tick_rate));
    if (sent) n.send_queue = *sent > link.remote_ack ? *sent - link.remote_ack : 0;
    n.interrupted = link.interrupted;
    return n;
}

}  // namespace lockroll::rollback
