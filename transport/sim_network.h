// In-process simulated network for N peers, driven in virtual time by a discrete-event loop.
//
// Determinism: every decision about a packet (loss, burst state, delay, duplication,
// reordering) is made when it is sent, from the network's private CounterRng stream for that
// directed link, at positions fixed by the packet's index on the link. The same seed, the same
// conditions and the same sends at the same times therefore give the same deliveries, bit for
// bit, on every platform; and a link's behaviour does not change when other links carry more
// or less traffic. Datagrams due at the same microsecond are delivered in send order (a global
// sequence number breaks the tie; a copy ranks right after its original).
//
// Partitions (transport/partition_schedule.h): a datagram sent across a cut while it is active
// is dropped before its link decides anything else (LinkModel::cut(): it still takes its packet
// index, so the datagrams that are not cut keep the fates they would have had) and is counted in
// the link's lost_partition and the sender's dropped. Without a schedule nothing is cut and
// every run is what it was before partitions existed.
//
// Endpoints are owned by the network and refer back to it, so the network is neither copyable
// nor movable and must outlive every use of its endpoints.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <queue>
#include <vector>

#include "transport/counter_rng.h"
#include "transport/link_conditions.h"
#include "transport/link_model.h"
#include "transport/partition_schedule.h"
#include "transport/transport.h"

namespace lockroll::transport {

struct SimNetworkConfig {
    int peers = 2;            // endpoint ids are 0 .. peers-1
    std::uint64_t seed = 1;
    LinkConditions link;      // initial conditions of every directed link
    std::size_t max_datagram_bytes = kMaxDatagramBytes;
    PartitionSchedule partitions{};  // times on the network's clock (the `now` of sends)
};

class SimNetwork {
public:
    // Throws std::invalid_argument naming the problem (peers outside 1..256, invalid link).
    explicit SimNetwork(const SimNetworkConfig& config);
    ~SimNetwork();
    SimNetwork(const SimNetwork&) = delete;
    SimNetwork& operator=(const SimNetwork&) = delete;

    int peer_count() const { return peers_; }

    // The Transport for one peer; ids outside 0..peers-1 throw std::out_of_range.
    Transport& endpoint(PeerId id);

    // Conditions apply to packets sent from now on; packets in flight keep their fate.
    // Invalid conditions or ids throw (std::invalid_argument / std::out_of_range).
    void set_link(PeerId from, PeerId to, const LinkConditions& link);
    void set_all_links(const LinkConditions& link);
    const LinkConditions& link(PeerId from, PeerId to) const;

    // Replaces the schedule, for datagrams sent from now on; slots must be peer ids (else
    // std::invalid_argument naming the slot).
    void set_partitions(const PartitionSchedule& partitions);
    const PartitionSchedule& partitions() const { return partitions_; }
    const LinkStats& link_stats(PeerId from, PeerId to) const;

    // Earliest time a datagram becomes deliverable (to anyone, or to one peer); nullopt when
    // nothing is in flight. A discrete-event loop jumps its clock here.
    std::optional<Micros> next_delivery_time() const;
    std::optional<Micros> next_delivery_time(PeerId to) const;
    std::size_t in_flight() const { return in_flight_; }

private:
    class Endpoint;
    friend class Endpoint;

    struct InFlight {
        Micros deliver_at;
        std::uint64_t sequence;
        PeerId from;
        std::vector<std::uint8_t> bytes;
    };
    struct Later {
        bool operator()(const InFlight& a, const InFlight& b) const {
            return a.deliver_at != b.deliver_at ? a.deliver_at > b.deliver_at : a.sequence > b.sequence;
        }
    };
    std::size_t link_index(PeerId from, PeerId to) const;
    void check_peer(PeerId id) const;
    // Decides the fate of one datagram (LinkModel) and queues its copies.
    PacketFate transmit(PeerId from, PeerId to, std::span<const std::uint8_t> bytes, Micros now);
    bool pop_due(PeerId to, Datagram& out, Micros now);

    int peers_;
    std::uint64_t seed_;
    std::size_t max_datagram_bytes_;
    std::vector<LinkModel> links_;  // from * peers + to
    PartitionSchedule partitions_;
    std::vector<std::priority_queue<InFlight, std::vector<InFlight>, Later>> queues_;  // by receiver
    std::vector<std::unique_ptr<Endpoint>> endpoints_;
    std::uint64_t next_sequence_ = 0;
    std::size_t in_flight_ = 0;
};

}  // namespace lockroll::transport
