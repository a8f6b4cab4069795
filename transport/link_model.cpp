#include "transport/link_model.h"

#include <algorithm>

namespace lockroll::transport {

namespace {

// Positions each packet owns in its link's stream; fixed so that packet n's draws never depend
// on what earlier packets needed.
constexpr std::uint64_t kSlotsPerPacket = 32;
enum Slot : std::uint64_t {
    kSlotBurstTransition = 0,
    kSlotBurstLoss = 1,
    kSlotLoss = 2,
    kSlotJitter = 3,  // 3..8: six draws = twelve 32-bit uniforms for the normal distribution
    kSlotReorder = 9,
    kSlotReorderDelay = 10,
    kSlotDuplicate = 11,
    kSlotDuplicateDelay = 12,
};

constexpr std::uint64_t kMicrosPerSecond = 1'000'000;

}  // namespace

void LinkModel::set_conditions(const LinkConditions& c) {
    conditions_ = c;
    loss_ = Chance::from_probability(c.loss);
    burst_enter_ = Chance::from_probability(c.burst_enter);
    burst_exit_ = Chance::from_probability(c.burst_exit);
    burst_loss_ = Chance::from_probability(c.burst_loss);
    duplicate_ = Chance::from_probability(c.duplicate);
    reorder_ = Chance::from_probability(c.reorder);
}

std::uint64_t LinkModel::begin_packet() {
    const std::uint64_t base = packets_++ * kSlotsPerPacket;
    ++stats_.sent;
    // Gilbert-Elliott: step the chain; the packet then meets the new state.
    const std::uint64_t transition = rng_.at(base + kSlotBurstTransition);
    if (bad_) {
        if (burst_exit_.hit(transition)) bad_ = false;
    } else if (burst_enter_.hit(transition)) {
        bad_ = true;
    }
    return base;
}

void LinkModel::cut() {
    begin_packet();
    ++stats_.lost_partition;
}

PacketFate LinkModel::transmit(std::size_t payload_bytes, Micros now) {
    const LinkConditions& c = conditions_;
    const std::uint64_t base = begin_packet();
    const auto draw = [&](std::uint64_t slot) { return rng_.at(base + slot); };
    PacketFate fate;
    if (bad_) ++stats_.burst_packets;

    // Bottleneck: serialise behind whatever is still being transmitted.
    Micros depart = now;
    if (c.bandwidth_bytes_per_s > 0) {
        const std::uint64_t wire = payload_bytes + c.per_packet_overhead_bytes;
        const auto tx = static_cast<Micros>(
            (static_cast<unsigned __int128>(wire) * kMicrosPerSecond + c.bandwidth_bytes_per_s - 1) /
            c.bandwidth_bytes_per_s);
        const Micros start = std::max(now, busy_until_);
        if (c.queue_limit_bytes > 0) {
            const auto backlog = static_cast<std::uint64_t>(
                static_cast<unsigned __int128>(start - now) * c.bandwidth_bytes_per_s / kMicrosPerSecond);
            if (backlog + wire > c.queue_limit_bytes) {
                ++stats_.lost_queue;
                return fate;
            }
        }
        busy_until_ = start + tx;
        depart = busy_until_;
    }

    if (bad_ && burst_loss_.hit(draw(kSlotBurstLoss))) {
        ++stats_.lost_burst;
        return fate;
    }
    if (loss_.hit(draw(kSlotLoss))) {
        ++stats_.lost_random;
        return fate;
    }

    // Propagation delay: latency plus jitter, never negative.
    __int128 offset = 0;
    const Micros j = c.jitter_us;
    if (j > 0) {
        if (c.jitter_distribution == JitterDistribution::Uniform) {
            offset = static_cast<__int128>(CounterRng::below(draw(kSlotJitter), 2 * j + 1)) - static_cast<__int128>(j);
        } else {
            // Sum of twelve uniform 32-bit values has mean 6 (2^32 - 1) and standard deviation
            // ~2^32; scaling by j / 2^32 gives standard deviation j.
            __int128 sum = 0;
            for (std::uint64_t k = 0; k < 6; ++k) {
                const std::uint64_t r = draw(kSlotJitter + k);
                sum += static_cast<__int128>(r >> 32) + static_cast<__int128>(r & 0xFFFFFFFFull);
            }
            const __int128 centred = sum - 6 * static_cast<__int128>(0xFFFFFFFFull);
            offset = (centred * static_cast<__int128>(j)) >> 32;  // floor
        }
    }
    const __int128 delay = std::max<__int128>(0, static_cast<__int128>(c.latency_us) + offset);
    Micros arrive = depart + static_cast<Micros>(delay);

    if (reorder_.hit(draw(kSlotReorder))) {
        // Held back: arrives late and does not hold up the packets behind it.
        arrive += c.reorder_min_us + CounterRng::below(draw(kSlotReorderDelay), c.reorder_max_us - c.reorder_min_us + 1);
        ++stats_.reordered;
        fate.reordered = true;
    } else {
        arrive = std::max(arrive, fifo_tail_);
        fifo_tail_ = arrive;
    }
    fate.delivered = true;
    fate.arrive_us = arrive;
    ++stats_.delivered;

    if (duplicate_.hit(draw(kSlotDuplicate))) {
        fate.duplicated = true;
        fate.copy_us = arrive + CounterRng::below(draw(kSlotDuplicateDelay), j + 1);
        ++stats_.delivered;
        ++stats_.duplicated;
    }
    return fate;
}

}  // namespace lockroll::transport
