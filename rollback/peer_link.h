// What a session knows about one remote peer's end of the conversation: how far it has
// acknowledged our inputs, how long a round trip takes, what frame it reported, what checksum we
// last told it, and whether it is still worth listening to.
//
// Why a sticky error state (as in yojimbo/netcode): a peer that keeps sending garbage is broken
// or hostile; after max_bad_packets malformed datagrams everything it sends is ignored, so a
// flood of bad bytes costs a counter increment each, never a decode, a crash or a desync.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/protocol.h"
#include "rollback/time_sync.h"

namespace lockroll::rollback {

class PeerLink {
public:
    PeerLink(int max_bad_packets, int time_sync_window)
        : max_bad_packets_(max_bad_packets), time_sync_(time_sync_window) {}

    // Counts a malformed datagram; true when this one tipped the peer into the error state.
    bool note_malformed(const char* why);
    bool error() const { return error_; }
    // A new process took the peer's place (rejoin): its predecessor's garbage is forgotten.
    void clear_error() {
        error_ = false;
        malformed_ = 0;
    }
    std::uint64_t malformed() const { return malformed_; }
    const std::string& last_error() const { return last_error_; }

    // Round-trip samples (µs): exponentially smoothed with weight 1/8, as TCP does.
    // Jitter: the mean deviation of samples from the smoothed RTT, weight 1/4 (TCP's rttvar).
    void add_rtt_sample(std::uint64_t us) {
        if (has_rtt_) {
            const std::uint64_t dev = us > rtt_us_ ? us - rtt_us_ : rtt_us_ - us;
            rtt_var_us_ = (3 * rtt_var_us_ + dev) / 4;
        }
        rtt_us_ = has_rtt_ ? (7 * rtt_us_ + us) / 8 : us;
        has_rtt_ = true;
    }
    bool has_rtt() const { return has_rtt_; }
    std::uint64_t rtt_us() const { return rtt_us_; }
    std::uint64_t rtt_var_us() const { return rtt_var_us_; }

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

    // ---- lifecycle (docs/sessions.md) ----
    bool welcomed = false;            // handshake done: its traffic is listened to
    std::uint8_t welcomed_epoch = 0;  // its slot's epoch when it was welcomed
    std::uint64_t incarnation = 0;    // the process welcomed (its hellos' incarnation)
    Role role = Role::Player;
    int roundtrips = 0;               // welcomes received (sync phase)
    std::uint64_t max_sync_rtt_us = 0;
    bool heard = false;
    std::uint64_t last_heard_us = 0;
    bool interrupted = false;
    std::uint64_t last_hello_us = 0;  // when we last said hello to it
    bool hello_sent = false;
    std::uint64_t last_refusal_us = 0;
    bool refusal_sent = false;
    // Its slot table as last reported, and how many inputs of each stream it holds (unwrapped);
    // has_count[s] false until it reported stream s.
    std::vector<SlotEntry> table;
    std::vector<bool> table_seen;
    std::vector<std::uint32_t> counts;
    std::vector<bool> has_count;
    // While a snapshot it pulls is being served: our queues keep inputs from this frame on.
    std::optional<std::uint32_t> pin_from;
    std::uint64_t pin_until_us = 0;
    // Round trip by echoed stamps (protocol.h, relay_messages.h; units of 100 µs, wrapping at
    // 2^16): its last stamp, and when it arrived.
    bool has_stamp = false;
    std::uint16_t stamp = 0;
    std::uint64_t stamp_at_us = 0;
    // What an outgoing message to it carries: our stamp (never kNoEcho), and its last stamp
    // echoed with how long we held it (both kNoEcho until it sent one).
    struct Stamps {
        std::uint16_t stamp = 0, echo = kNoEcho, hold = kNoEcho;
    };
    static constexpr std::uint16_t kNoEcho = 0xFFFF;
    Stamps outgoing_stamps(std::uint64_t now_us) const;
    // An incoming message's stamps: a round-trip sample from its echo of ours (minus the time
    // it held it; none when it echoes nothing, or the numbers cannot be true), then its stamp
    // is remembered for our next echo.
    void take_stamps(std::uint16_t stamp, std::uint16_t echo, std::uint16_t hold, std::uint64_t now_us);

    void reset_lifecycle(std::size_t slots) {
        table.assign(slots, SlotEntry{});
        table_seen.assign(slots, false);
        counts.assign(slots, 0);
        has_count.assign(slots, false);
        pin_from.reset();
        has_stamp = false;
        interrupted = false;
        remote_ack = 0;
        has_remote_frame = false;
        any_checksum_sent = false;
        checksum_sends = 0;
    }

private:
    int max_bad_packets_;
    bool error_ = false;
    std::uint64_t malformed_ = 0;
    std::string last_error_;
    bool has_rtt_ = false;
    std::uint64_t rtt_us_ = 0;
    std::uint64_t rtt_var_us_ = 0;
    TimeSync time_sync_;
};

}  // namespace lockroll::rollback
