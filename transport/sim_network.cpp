#include "transport/sim_network.h"

#include <algorithm>
#include <stdexcept>
#include <string>

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

constexpr int kMaxPeers = 256;
constexpr std::uint64_t kMicrosPerSecond = 1'000'000;

}  // namespace

class SimNetwork::Endpoint final : public Transport {
public:
    Endpoint(SimNetwork& net, PeerId id) : net_(net), id_(id) {}

    PeerId local_id() const override { return id_; }

    bool send(PeerId to, std::span<const std::uint8_t> bytes, Micros now) override {
        if (to == id_ || to >= static_cast<PeerId>(net_.peer_count()) || bytes.size() > net_.max_datagram_bytes_) {
            ++counters_.rejected;
            return false;
        }
        ++counters_.datagrams_sent;
        counters_.bytes_sent += bytes.size();
        const Fate fate = net_.transmit(id_, to, bytes, now);
        if (!fate.delivered) ++counters_.dropped;
        if (fate.duplicated) ++counters_.duplicated;
        return true;
    }

    bool receive(Datagram& out, Micros now) override {
        if (!net_.pop_due(id_, out, now)) return false;
        ++counters_.datagrams_received;
        counters_.bytes_received += out.bytes.size();
        return true;
    }

    const TransportCounters& counters() const override { return counters_; }

private:
    SimNetwork& net_;
    PeerId id_;
    TransportCounters counters_;
};

SimNetwork::SimNetwork(const SimNetworkConfig& config)
    : peers_(config.peers), seed_(config.seed), max_datagram_bytes_(config.max_datagram_bytes) {
    if (config.peers < 1 || config.peers > kMaxPeers)
        throw std::invalid_argument("SimNetwork: peers must be in 1.." + std::to_string(kMaxPeers) + ", got " +
                                    std::to_string(config.peers));
    if (const std::string err = validate(config.link); !err.empty())
        throw std::invalid_argument("SimNetwork: link: " + err);
    const auto n = static_cast<std::size_t>(config.peers);
    links_.resize(n * n);
    for (PeerId from = 0; from < n; ++from)
        for (PeerId to = 0; to < n; ++to) {
            Link& link = links_[link_index(from, to)];
            link.rng = CounterRng::derive(seed_, from, to);
            configure(link, config.link);
        }
    queues_.resize(n);
    for (PeerId id = 0; id < n; ++id) endpoints_.push_back(std::make_unique<Endpoint>(*this, id));
}

SimNetwork::~SimNetwork() = default;

void SimNetwork::check_peer(PeerId id) const {
    if (id >= static_cast<PeerId>(peer_count()))
        throw std::out_of_range("SimNetwork: peer id " + std::to_string(id) + " is not in 0.." +
                                std::to_string(peer_count() - 1));
}

std::size_t SimNetwork::link_index(PeerId from, PeerId to) const {
    return static_cast<std::size_t>(from) * static_cast<std::size_t>(peer_count()) + to;
}

Transport& SimNetwork::endpoint(PeerId id) {
    check_peer(id);
    return *endpoints_[id];
}

void SimNetwork::configure(Link& link, const LinkConditions& c) {
    link.conditions = c;
    link.loss = Chance::from_probability(c.loss);
    link.burst_enter = Chance::from_probability(c.burst_enter);
    link.burst_exit = Chance::from_probability(c.burst_exit);
    link.burst_loss = Chance::from_probability(c.burst_loss);
    link.duplicate = Chance::from_probability(c.duplicate);
    link.reorder = Chance::from_probability(c.reorder);
}

void SimNetwork::set_link(PeerId from, PeerId to, const LinkConditions& link) {
    check_peer(from);
    check_peer(to);
    if (const std::string err = validate(link); !err.empty())
        throw std::invalid_argument("SimNetwork: link " + std::to_string(from) + "->" + std::to_string(to) + ": " + err);
    configure(links_[link_index(from, to)], link);
}

void SimNetwork::set_all_links(const LinkConditions& link) {
    if (const std::string err = validate(link); !err.empty())
        throw std::invalid_argument("SimNetwork: link: " + err);
    for (Link& l : links_) configure(l, link);
}

const LinkConditions& SimNetwork::link(PeerId from, PeerId to) const {
    check_peer(from);
    check_peer(to);
    return links_[link_index(from, to)].conditions;
}

const LinkStats& SimNetwork::link_stats(PeerId from, PeerId to) const {
    check_peer(from);
    check_peer(to);
    return links_[link_index(from, to)].stats;
}

std::optional<Micros> SimNetwork::next_delivery_time() const {
    std::optional<Micros> best;
    for (const auto& q : queues_)
        if (!q.empty() && (!best || q.top().deliver_at < *best)) best = q.top().deliver_at;
    return best;
}

std::optional<Micros> SimNetwork::next_delivery_time(PeerId to) const {
    check_peer(to);
    const auto& q = queues_[to];
    if (q.empty()) return std::nullopt;
    return q.top().deliver_at;
}

SimNetwork::Fate SimNetwork::transmit(PeerId from, PeerId to, std::span<const std::uint8_t> bytes, Micros now) {
    Link& link = links_[link_index(from, to)];
    const LinkConditions& c = link.conditions;
    const std::uint64_t base = link.packets++ * kSlotsPerPacket;
    const auto draw = [&](std::uint64_t slot) { return link.rng.at(base + slot); };
    ++link.stats.sent;

    // Gilbert-Elliott: step the chain, then the packet meets the new state.
    if (link.bad) {
        if (link.burst_exit.hit(draw(kSlotBurstTransition))) link.bad = false;
    } else if (link.burst_enter.hit(draw(kSlotBurstTransition))) {
        link.bad = true;
    }
    if (link.bad) ++link.stats.burst_packets;

    // Bottleneck: serialise behind whatever is still being transmitted.
    Micros depart = now;
    if (c.bandwidth_bytes_per_s > 0) {
        const std::uint64_t wire = bytes.size() + c.per_packet_overhead_bytes;
        const auto tx = static_cast<Micros>(
            (static_cast<unsigned __int128>(wire) * kMicrosPerSecond + c.bandwidth_bytes_per_s - 1) /
            c.bandwidth_bytes_per_s);
        const Micros start = std::max(now, link.busy_until);
        if (c.queue_limit_bytes > 0) {
            const auto backlog = static_cast<std::uint64_t>(
                static_cast<unsigned __int128>(start - now) * c.bandwidth_bytes_per_s / kMicrosPerSecond);
            if (backlog + wire > c.queue_limit_bytes) {
                ++link.stats.lost_queue;
                return {false, false};
            }
        }
        link.busy_until = start + tx;
        depart = link.busy_until;
    }

    if (link.bad && link.burst_loss.hit(draw(kSlotBurstLoss))) {
        ++link.stats.lost_burst;
        return {false, false};
    }
    if (link.loss.hit(draw(kSlotLoss))) {
        ++link.stats.lost_random;
        return {false, false};
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

    if (link.reorder.hit(draw(kSlotReorder))) {
        // Held back: arrives late and does not hold up the packets behind it.
        arrive += c.reorder_min_us + CounterRng::below(draw(kSlotReorderDelay), c.reorder_max_us - c.reorder_min_us + 1);
        ++link.stats.reordered;
    } else {
        arrive = std::max(arrive, link.fifo_tail);
        link.fifo_tail = arrive;
    }

    const std::vector<std::uint8_t> payload(bytes.begin(), bytes.end());
    queues_[to].push(InFlight{arrive, next_sequence_++, from, payload});
    ++in_flight_;
    ++link.stats.delivered;

    const bool dup = link.duplicate.hit(draw(kSlotDuplicate));
    if (dup) {
        const Micros copy_at = arrive + CounterRng::below(draw(kSlotDuplicateDelay), j + 1);
        queues_[to].push(InFlight{copy_at, next_sequence_++, from, payload});
        ++in_flight_;
        ++link.stats.delivered;
        ++link.stats.duplicated;
    }
    return {true, dup};
}

bool SimNetwork::pop_due(PeerId to, Datagram& out, Micros now) {
    auto& q = queues_[to];
    if (q.empty() || q.top().deliver_at > now) return false;
    const InFlight& top = q.top();
    out.from = top.from;
    out.time_us = top.deliver_at;
    out.bytes.assign(top.bytes.begin(), top.bytes.end());
    q.pop();
    --in_flight_;
    return true;
}

}  // namespace lockroll::transport
