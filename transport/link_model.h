// One directed link's behaviour, packet by packet: decides at send time whether a datagram is
// lost (independent, burst or queue), when it arrives, and whether a copy follows. Both the
// in-process SimNetwork (virtual time) and the real-time UDP proxy (net/udp_proxy) use it, so
// `--latency/--jitter/--loss/...` mean exactly the same thing in `lockroll run` and
// `lockroll proxy` (model in docs/network-model.md).
//
// Contract
//  - Pure function of (stream key, conditions, packet index on the link, packet size, send time
//    and the link's carried state: burst state, in-order tail, bottleneck busy time). Never reads
//    a clock; packet n draws only positions 32n .. 32n+31 of its CounterRng stream.
//  - Conditions may change between packets; packets already decided keep their fate.
//  - A datagram a partition cuts (cut()) takes its packet index and steps the burst chain like
//    any other, so every datagram that is not cut meets the same draws and burst state as it
//    would without the partition; with no cut ever made, nothing differs from a link without
//    partitions at all.
//  - Callers validate conditions first (validate(LinkConditions)); set_conditions trusts them.
#pragma once

#include <cstddef>
#include <cstdint>

#include "transport/counter_rng.h"
#include "transport/link_conditions.h"
#include "transport/transport.h"

namespace lockroll::transport {

// What happens to one datagram. When `delivered`, it arrives at `arrive_us`; when also
// `duplicated`, a copy arrives at `copy_us` (>= arrive_us).
struct PacketFate {
    bool delivered = false;
    bool duplicated = false;
    bool reordered = false;
    Micros arrive_us = 0;
    Micros copy_us = 0;
};

class LinkModel {
public:
    LinkModel() = default;
    LinkModel(CounterRng rng, const LinkConditions& conditions) : rng_(rng) { set_conditions(conditions); }

    void set_conditions(const LinkConditions& conditions);
    const LinkConditions& conditions() const { return conditions_; }

    // Decides the fate of a datagram of `payload_bytes` sent at `now` and counts it in stats().
    PacketFate transmit(std::size_t payload_bytes, Micros now);

    // A datagram cut by a partition before it enters the link (transport/partition_schedule.h):
    // it owns packet index n and its burst-chain transition, as in transmit(), but never reaches
    // the bottleneck or the in-order tail. Counted in sent and lost_partition only.
    void cut();

    const LinkStats& stats() const { return stats_; }

private:
    // Takes the next packet index, steps the Gilbert-Elliott chain with its transition draw and
    // counts the packet as sent; returns the index's first stream position.
    std::uint64_t begin_packet();

    LinkConditions conditions_;
    Chance loss_, burst_enter_, burst_exit_, burst_loss_, duplicate_, reorder_;
    CounterRng rng_{0};
    std::uint64_t packets_ = 0;  // index of the next packet on this link
    bool bad_ = false;           // Gilbert-Elliott state
    Micros fifo_tail_ = 0;       // latest in-order arrival so far
    Micros busy_until_ = 0;      // bottleneck transmitter free from this time
    LinkStats stats_;
};

}  // namespace lockroll::transport
