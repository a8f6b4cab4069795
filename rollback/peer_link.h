// What a session knows about one remote peer's end of the conversation: how far it has
// acknowledged our inputs, how long a round trip takes, what frame it reported, what checksum we
// last told it, and whether it is still worth listening to.
//
// Why a sticky error state (as in yojimbo/netcode): a peer that keeps sending garbage is broken
// or hostile; after max_bad_packets malformed datagrams everything it sends is ignored, so a
// flood of bad bytes costs a counter increment each, never a decode, a crash or a desync.
#pragma once

#include <cstdint>
#include <string>

#include "rollback/time_sync.h"

namespace lockroll::rollback {

class PeerLink {
public:
    PeerLink(int max_bad_packets, int time_sync_window)
        : max_bad_packets_(max_bad_packets), time_sync_(time_sync_window) {}

    // Counts a malformed datagram; true when this one tipped the peer into the error state.
    bool note_malformed(const char* why) {
        last_error_ = why;
        ++malformed_;
        if (!error_ && malformed_ >= static_cast<std::uint64_t>(max_bad_packets_)) {
            error_ = true;
            return true;
        }
        return false;
    }
    bool error() const { return error_; }
    std::uint64_t malformed() const { return malformed_; }
    const std::string& last_error() const { return last_error_; }

    // Round-trip samples (µs): exponentially smoothed with weight 1/8, as TCP does.
    void add_rtt_sample(std::uint64_t us) {
        rtt_us_ = has_rtt_ ? (7 * rtt_us_ + us) / 8 : us;
        has_rtt_ = true;
    }
    bool has_rtt() const { return has_rtt_; }
    std::uint64_t rtt_us() const { return rtt_us_; }

    TimeSync& time_sync() { return time_sync_; }
    const TimeSync& time_sync() const { return time_sync_; }

    // First of our local input frames the peer still needs (its confirmed count of our inputs).
    std::uint32_t remote_ack = 0;

    // The peer's last reported displayed frame, when we received it, and its own advantage
    // estimate (receiver frame - sender frame, from its point of view).
    bool has_remote_frame = false;
    std::uint32_t remote_frame = 0;
    std::uint64_t remote_frame_time_us = 0;
    std::int8_t remote_advantage = 0;

    // Checksum piggybacking: the newest confirmed checkpoint announced, and how many messages
    // carried it (it is repeated while nothing newer is confirmed).
    std::uint32_t checksum_frame_sent = 0;
    int checksum_sends = 0;
    bool any_checksum_sent = false;

    std::uint64_t messages_sent = 0;

private:
    int max_bad_packets_;
    bool error_ = false;
    std::uint64_t malformed_ = 0;
    std::string last_error_;
    bool has_rtt_ = false;
    std::uint64_t rtt_us_ = 0;
    TimeSync time_sync_;
};

}  // namespace lockroll::rollback
