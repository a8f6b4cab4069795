// One remote peer's end of the conversation, as the session's per-peer endpoint (GGRS's
// UdpProtocol; the Session delegates each peer to one): the handshake (hellos due, welcomes and
// the sync-phase round trips, refusals rate-limited), liveness (heard, interrupted, timed out),
// round trip (smoothed samples, echoed stamps), input exchange (its acks of our inputs, its
// reported frame and advantage, our estimate of its frame now), which confirmed checksums ride
// on the next message to it and when our slot table does; whether it is still worth
// listening to; and its numbers for an overlay (network_stats(), below). The session decides
// what the answers mean for the match (votes, events, membership); the link holds no session
// state and reads no clock (time is passed in).
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
#include "rollback/session.h"
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

    // ---- liveness ----
    // Heard now (without ending an interruption).
    void mark_heard(std::uint64_t now_us) {
        heard = true;
        last_heard_us = now_us;
    }
    // A datagram that proves it alive: heard now; true when this ended an interruption.
    bool hear(std::uint64_t now_us);
    // What its silence says now. Nothing until it was first heard; interrupted_now once per
    // silence of interrupt_us; timed_out while silent for disconnect_us (0: never).
    struct Silence {
        bool interrupted_now = false;
        bool timed_out = false;
        std::uint64_t silent_us = 0;
    };
    Silence check_silence(std::uint64_t now_us, std::uint64_t interrupt_us, std::uint64_t disconnect_us);

    // ---- handshake ----
    // A hello is due every resend_us; true marks it said now.
    bool hello_due(std::uint64_t now_us, std::uint64_t resend_us);
    // No refusal went to it within gap_us.
    bool refusal_quiet_for(std::uint64_t now_us, std::uint64_t gap_us) const {
        return !refusal_sent || now_us >= last_refusal_us + gap_us;
    }
    void mark_refusal(std::uint64_t now_us) {
        refusal_sent = true;
        last_refusal_us = now_us;
    }
    // Its welcome of our hello in the sync phase: a round-trip sample from its echo of the
    // hello's time (none from an echo in the future), the worst such sample, one more round trip
    // (counted to 1000), heard now; running: it plays already. True when this was its first.
    bool sync_welcome(std::uint64_t echo_us, bool running, std::uint64_t now_us);
    // A late welcome once we run (a joiner's link to a running slot comes up after the load):
    // the link is live from now on, in the slot's epoch.
    void late_welcome(std::uint8_t epoch, std::uint64_t echo_us, std::uint64_t now_us);
    // We welcome its hello: a process of `role`, `incarnation`, welcomed in its slot's epoch
    // (none for a spectator); heard now unless heard before.
    void accept_hello(Role r, std::uint64_t process, std::optional<std::uint8_t> epoch, std::uint64_t now_us);

    // ---- input exchange ----
    // Its ack of our inputs: true when it moved forward.
    bool take_ack(std::uint32_t ack) {
        if (ack <= remote_ack) return false;
        remote_ack = ack;
        return true;
    }
    // Its reported displayed frame and advantage (already clipped by the caller), heard now.
    void note_remote_frame(std::uint32_t frame, std::int8_t advantage, std::uint64_t now_us) {
        has_remote_frame = true;
        remote_frame = frame;
        remote_frame_time_us = now_us;
        remote_advantage = advantage;
    }
    // Its displayed frame now, estimated: the last one it reported, advanced by the time since
    // (at most interrupt_us: a silent peer is not running ahead) plus half a round trip.
    std::int64_t estimated_frame(std::uint64_t now_us, std::uint64_t interrupt_us, int tick_rate) const;
    // The confirmed checksums for the next message to it (players only): every checkpoint
    // (multiple of interval) since the last one announced, newest `max` at most, else the newest
    // again until it rode `repeats` messages. checksum(f) gives our checksum of frame f if we
    // still hold it. Writes frames and checksums, returns how many.
    template <class Checksum>
    int pick_checksums(std::uint32_t checkpoint, std::uint32_t interval, int repeats, std::uint32_t max, Checksum&& checksum,
                       std::uint16_t* frames, std::uint64_t* sums);

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

    // ---- our slot table to it (issue 21: sent when it changes, plus a slow refresh) ----
    // The table's entries as they would go to it now, one per slot (state << 8 | epoch: our vote
    // or view), decide when it rides. When they differ from the ones last sent, it rides on the
    // next message and then again 1, 2, 4, ... messages after the change, `copies` times in all:
    // a vote is one datagram, and copies spread over about 2^(copies-2) messages survive a loss
    // burst as well as independent loss (all 8 copies lost at 30 % loss: 7e-5). Otherwise, once
    // its entries changed at least once, it rides when refresh_us have passed since it last did
    // (0: never), which repairs a change all of whose copies were lost. A table that never
    // changed has nothing to repair: the peer already holds what it says (table_assumed). The
    // caller sends it for reasons of its own too (a slot not simply running, relays): every copy
    // that went counts (table_sent).
    bool table_due(const std::vector<std::uint16_t>& entries, std::uint64_t now_us, std::uint64_t refresh_us) const;
    // The table went on the message about to be counted in messages_sent, now, with these
    // entries; copies: how many copies a change of entries gets.
    void table_sent(const std::vector<std::uint16_t>& entries, std::uint64_t now_us, int copies);
    // The peer holds these entries without our sending them (the starting view, from the config
    // both share): they are no change, and nothing needs a refresh yet.
    void table_assumed(const std::vector<std::uint16_t>& entries, std::uint64_t now_us);
    // When its last table arrived: its counts are what relays are decided from, and counts
    // older than a few tables say nothing about a lag now.
    std::uint64_t counts_at_us = 0;

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
        // Heard only once the new process speaks (its accepted hello, its join, its spectate):
        // the previous one's silence is not its own (a spectator back after its timeout was
        // timed out again at once, its predecessor's last word the newest heard).
        heard = false;
        interrupted = false;
        remote_ack = 0;
        has_remote_frame = false;
        any_checksum_sent = false;
        checksum_sends = 0;
        counts_at_us = 0;
        // A new process there has heard nothing from us: our table is a change to it.
        table_entries_sent_.clear();
        table_copies_ = 0;
        table_changed_ = false;
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
    std::vector<std::uint16_t> table_entries_sent_;  // empty: none sent, any table is a change
    int table_copies_ = 0;                           // copies of them sent since they changed
    int table_copies_wanted_ = 0;
    std::uint64_t table_change_message_ = 0;         // messages_sent when they changed
    std::uint64_t table_sent_us_ = 0;
    bool table_changed_ = false;                     // entries it got from us, not assumed
};

template <class Checksum>
int PeerLink::pick_checksums(std::uint32_t cp, std::uint32_t k, int repeats, std::uint32_t max, Checksum&& checksum,
                             std::uint16_t* frames, std::uint64_t* sums) {
    int n = 0;
    if (!any_checksum_sent || cp > checksum_frame_sent) {
        std::uint32_t oldest = cp;
        while (oldest >= k && cp - (oldest - k) < k * max && (!any_checksum_sent || oldest - k > checksum_frame_sent))
            oldest -= k;
        for (std::uint32_t f = oldest; f <= cp; f += k) {
            if (const auto c = checksum(f)) {
                frames[n] = static_cast<std::uint16_t>(f);
                sums[n] = *c;
                ++n;
            }
        }
        any_checksum_sent = true;
        checksum_frame_sent = cp;
        checksum_sends = 1;
    } else if (checksum_sends < repeats) {
        if (const auto c = checksum(cp)) {
            ++checksum_sends;
            frames[0] = static_cast<std::uint16_t>(cp);
            sums[0] = *c;
            n = 1;
        }
    }
    return n;
}

// One peer's numbers for an overlay (Session::network_stats): its round trip and jitter, the
// payload rates since the match started (`seconds` ago; 0: none yet), how far it is estimated
// behind our `frame` (once it reported one), and how many of our inputs it has not acknowledged
// (`sent`: our stream's count; none for a spectator, which sends no inputs).
struct OverlayClock {
    std::uint32_t frame = 0;
    double seconds = 0;
    std::uint64_t now_us = 0;
    std::uint64_t interrupt_us = 0;
    int tick_rate = 60;
};
NetworkStats network_stats(const PeerLink& link, const PeerStats& traffic, const OverlayClock& at,
                           std::optional<std::uint32_t> sent);

}  // namespace lockroll::rollback
