// RedialBackoff: when the runner dials a peer it is not connected to again. A pure policy over
// time passed in (no clock here): the runner (net/peer_runner.cpp) asks it per peer id.
//
// Why: a peer that is gone (killed, its machine off, a partition) must still come back when it
// restarts or the network heals, so its address is never given up; but dialing a gone address
// at a fixed half-second rate for a whole run is traffic and connection churn for nothing.
//
// Contract
//  - Each peer id starts due (the first dial is at once).
//  - dialed(id, now): the next dial of that id is due `interval` after now; the interval starts
//    at kFirstUs (0.5 s) and doubles after each dial up to kCapUs (4 s). So a gone address is
//    dialed at 0, 0.5, 1.5, 3.5, 7.5 s, then every 4 s: 18 dials in the first minute instead
//    of 120, and a restarted peer or a healed partition is dialed again at most 4 s after it is back.
//  - heard(id): the peer was heard (its connection came up), or is known to be back (the
//    runner's session says its slot joined): the interval starts over at kFirstUs and the id
//    is due at once, so the first redial after it is lost again is immediate and the next ones
//    fast (a quick restart is reconnected quickly).
//  - due(id, now): whether to dial it now. Ids out of range are never due.
//  - try_dial(id, now, connect): the runner's step. If due, calls connect(); a dial counts
//    (dialed) only if connect() started an attempt. One it refused -- above all because the
//    last attempt is still pending -- is no dial: the id is due again kRecheckUs later at the
//    same interval, so an attempt that fails is followed within kRecheckUs by a new one. (Issue
//    21: a survivor's dial to a killed slot's address, due just as the slot came back, was
//    refused by the doomed attempt still pending from before, and charged all the same; the
//    pending attempt failed 2 ms later, and the next dial, 4 s on, was the first to reach the
//    rejoiner: its snapshot was refused twice as "cut off from a majority", the handoff lapsed
//    and it ran out its connect timeout.)
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace lockroll::net {

class RedialBackoff {
public:
    static constexpr std::uint64_t kFirstUs = 500000;
    static constexpr std::uint64_t kCapUs = 4000000;
    static constexpr std::uint64_t kRecheckUs = 50000;

    explicit RedialBackoff(std::size_t ids = 0) : peers_(ids) {}

    bool due(std::size_t id, std::uint64_t now_us) const;
    void dialed(std::size_t id, std::uint64_t now_us);
    void heard(std::size_t id);
    // Dials `id` if due: connect() says whether an attempt started. Returns whether it did.
    bool try_dial(std::size_t id, std::uint64_t now_us, const std::function<bool()>& connect);
    // The interval the next dial of `id` waits after the one before it (µs).
    std::uint64_t interval_us(std::size_t id) const;

private:
    struct Peer {
        std::uint64_t next_us = 0;
        std::uint64_t interval_us = kFirstUs;
    };
    std::vector<Peer> peers_;
};

}  // namespace lockroll::net
