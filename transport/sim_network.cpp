#include "transport/sim_network.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace lockroll::transport {

namespace {

constexpr int kMaxPeers = 256;

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
        const PacketFate fate = net_.transmit(id_, to, bytes, now);
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
        for (PeerId to = 0; to < n; ++to)
            links_[link_index(from, to)] = LinkModel(CounterRng::derive(seed_, from, to), config.link);
    set_partitions(config.partitions);
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

void SimNetwork::set_link(PeerId from, PeerId to, const LinkConditions& link) {
    check_peer(from);
    check_peer(to);
    if (const std::string err = validate(link); !err.empty())
        throw std::invalid_argument("SimNetwork: link " + std::to_string(from) + "->" + std::to_string(to) + ": " + err);
    links_[link_index(from, to)].set_conditions(link);
}

void SimNetwork::set_all_links(const LinkConditions& link) {
    if (const std::string err = validate(link); !err.empty())
        throw std::invalid_argument("SimNetwork: link: " + err);
    for (LinkModel& l : links_) l.set_conditions(link);
}

void SimNetwork::set_partitions(const PartitionSchedule& partitions) {
    if (const std::string err = partitions.check_slots(peers_); !err.empty())
        throw std::invalid_argument("SimNetwork: partition: " + err);
    partitions_ = partitions;
}

const LinkConditions& SimNetwork::link(PeerId from, PeerId to) const {
    check_peer(from);
    check_peer(to);
    return links_[link_index(from, to)].conditions();
}

const LinkStats& SimNetwork::link_stats(PeerId from, PeerId to) const {
    check_peer(from);
    check_peer(to);
    return links_[link_index(from, to)].stats();
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

PacketFate SimNetwork::transmit(PeerId from, PeerId to, std::span<const std::uint8_t> bytes, Micros now) {
    LinkModel& link = links_[link_index(from, to)];
    if (partitions_.is_cut(from, to, now)) {
        link.cut();
        return PacketFate{};
    }
    const PacketFate fate = link.transmit(bytes.size(), now);
    if (!fate.delivered) return fate;
    const std::vector<std::uint8_t> payload(bytes.begin(), bytes.end());
    queues_[to].push(InFlight{fate.arrive_us, next_sequence_++, from, payload});
    ++in_flight_;
    if (fate.duplicated) {
        queues_[to].push(InFlight{fate.copy_us, next_sequence_++, from, payload});
        ++in_flight_;
    }
    return fate;
}

bool SimNetwork::pop_due(PeerId to, Datagram& out, Micros now) {
    auto& q = queues_[to];
    if (q.empty() || q.top().deliver_at > now) return false;
    const InFlight& top = q.top();
    out.from = top.from;
    out.time_us = top.deliver_at;
    out.bytes.assign(top.bytes.begin(), top.bytes.end());
    out.reliable = false;
    q.pop();
    --in_flight_;
    return true;
}

}  // namespace lockroll::transport
