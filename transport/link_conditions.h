// What one direction of a simulated link does to packets (model in docs/network-model.md).
// Plain data: the harness fills it from the command line, SimNetwork applies it per directed
// link, and can change it mid-run (a latency spike, a burst of loss).
#pragma once

#include <cstdint>
#include <string>

#include <lockroll/transport/transport.h>

namespace lockroll::transport {

enum class JitterDistribution : std::uint8_t {
    // Delay offset uniform in [-jitter, +jitter] (integer microseconds, both ends included).
    Uniform = 0,
    // Approximately normal with standard deviation jitter: the Irwin-Hall sum of twelve uniform
    // 32-bit draws, so integer-exact everywhere and bounded to +-6 sigma.
    Normal = 1,
};

struct LinkConditions {
    Micros latency_us = 0;  // one-way base delay
    Micros jitter_us = 0;   // see JitterDistribution; the total delay never goes below 0
    JitterDistribution jitter_distribution = JitterDistribution::Uniform;

    // Independent per-packet loss, in any Gilbert-Elliott state.
    double loss = 0.0;

    // Burst loss (Gilbert-Elliott): per packet the link moves Good -> Bad with burst_enter and
    // Bad -> Good with burst_exit, then a packet in Bad is lost with burst_loss. Mean burst
    // length is 1 / burst_exit packets; the long-run fraction of packets sent in Bad is
    // burst_enter / (burst_enter + burst_exit). burst_enter = 0 turns bursts off.
    double burst_enter = 0.0;
    double burst_exit = 0.5;
    double burst_loss = 1.0;

    // Probability that a delivered packet arrives twice. The copy arrives after the original,
    // by a uniform extra delay in [0, jitter_us].
    double duplicate = 0.0;

    // Jitter alone keeps a link in order (packets queue behind the one before, as in a router).
    // With probability `reorder` a packet is instead held back by an extra delay uniform in
    // [reorder_min_us, reorder_max_us] and is overtaken by everything sent during that time.
    double reorder = 0.0;
    Micros reorder_min_us = 20'000;
    Micros reorder_max_us = 50'000;

    // Optional bottleneck: the link serialises (payload + per_packet_overhead_bytes) at this rate
    // before the propagation delay; 0 means unlimited. With queue_limit_bytes > 0 a packet that
    // would find more than that many bytes queued ahead of it is dropped (drop-tail).
    std::uint64_t bandwidth_bytes_per_s = 0;
    std::uint32_t per_packet_overhead_bytes = 28;  // IPv4 + UDP
    std::uint64_t queue_limit_bytes = 0;
};

// Empty when usable; otherwise a message naming the field (probabilities must be in [0, 1],
// reorder_min_us <= reorder_max_us, burst_exit > 0 when bursts are on).
std::string validate(const LinkConditions& link);

// Per-link statistics, counted as the network decides each packet's fate at send time.
struct LinkStats {
    std::uint64_t sent = 0;          // datagrams offered to the link, cut ones included
    std::uint64_t delivered = 0;     // datagrams scheduled for delivery, copies included
    std::uint64_t lost_random = 0;   // independent loss
    std::uint64_t lost_burst = 0;    // lost in the Gilbert-Elliott Bad state
    std::uint64_t lost_queue = 0;    // drop-tail at the bandwidth bottleneck
    std::uint64_t lost_partition = 0;  // cut by a partition (transport/partition_schedule.h)
    std::uint64_t duplicated = 0;
    std::uint64_t reordered = 0;     // held back by the reorder model
    std::uint64_t burst_packets = 0; // packets that found the link in the Bad state
};

}  // namespace lockroll::transport
