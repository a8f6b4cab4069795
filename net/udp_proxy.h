// A UDP impairment proxy for real processes on loopback: clients send to the proxy's listen
// address, the proxy forwards to one upstream server and relays the replies, applying the
// simulated network's link model (transport/link_model.h) to every datagram in both directions,
// so `lockroll proxy --latency 50 --loss 0.2` does to real traffic what `lockroll run` does in
// virtual time.
//
// Contract
//  - Each client source address gets its own upstream socket (the server sees one distinct
//    source per client) and its own pair of directed links, seeded from (seed, client index):
//    the i-th client to appear gets links derive(seed, i+1, 0) up and derive(seed, 0, i+1) down.
//  - Only ever binds the listen address and sends to the upstream address and to clients that
//    sent to it first. Callers (the CLI) check both addresses are loopback.
//  - Bounded: at most max_clients clients (others are ignored and counted), at most max_queued
//    datagrams / max_queued_bytes waiting for their delivery time (the rest dropped, counted),
//    idle clients (nothing either way for client_idle_us) forgotten with their socket.
//  - Partitions: with a schedule, the slot of the server (upstream_slot) and the slots of clients
//    by source address (client_slots), a datagram either way between a client and the server is
//    dropped while a cut separates their slots, the schedule's time 0 being partition_epoch_us on
//    net::now_us(). The link model still sees it (LinkModel::cut: same draws for the rest); it
//    counts as partitioned, not as dropped. A client with no slot, or a proxy with no
//    upstream_slot, is never cut; before the epoch nothing is.
//  - Reads the clock (net::now_us) to time deliveries: it lives in the real-time layer.
//  - Not thread-safe. Socket errors on send/receive are counted, never fatal.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "net/udp_address.h"
#include "transport/link_model.h"
#include "transport/partition_schedule.h"

namespace lockroll::net {

struct UdpProxyConfig {
    UdpAddress listen;                 // where clients send (port 0: ephemeral, see port())
    UdpAddress upstream;               // the server
    transport::LinkConditions link;    // applied to each direction of each client
    std::uint64_t seed = 1;
    std::size_t max_clients = 64;
    std::size_t max_queued = 16'384;
    std::size_t max_queued_bytes = 16u << 20;
    std::uint64_t client_idle_us = 60'000'000;
    // Partitions (see the contract): times in the schedule are microseconds since the epoch.
    transport::PartitionSchedule partitions;
    std::uint64_t partition_epoch_us = 0;
    std::optional<transport::PeerId> upstream_slot;
    std::vector<std::pair<UdpAddress, transport::PeerId>> client_slots;
};

struct UdpProxyCounters {
    std::uint64_t received = 0;        // datagrams read, both directions
    std::uint64_t forwarded = 0;       // datagrams written, copies included
    std::uint64_t dropped = 0;         // lost by the link model (loss, bursts, bottleneck)
    std::uint64_t partitioned = 0;     // cut by a partition (not in dropped)
    std::uint64_t duplicated = 0;      // extra copies made
    std::uint64_t reordered = 0;       // held back by the reorder model
    std::uint64_t queue_full = 0;      // dropped because the delay queue was full
    std::uint64_t clients = 0;         // client addresses seen
    std::uint64_t refused_clients = 0; // datagrams from clients beyond max_clients
    std::uint64_t socket_errors = 0;   // failed sends / receives (e.g. ICMP port unreachable)
};

class UdpProxy {
public:
    // Binds the listen socket; throws std::runtime_error naming the address on failure and
    // std::invalid_argument for invalid link conditions.
    explicit UdpProxy(const UdpProxyConfig& config);
    ~UdpProxy();
    UdpProxy(const UdpProxy&) = delete;
    UdpProxy& operator=(const UdpProxy&) = delete;

    std::uint16_t port() const { return port_; }
    const UdpProxyCounters& counters() const { return counters_; }

    // Serves until `stop` is set or the clock reaches deadline_us (0: no deadline). Wakes at
    // least every 50 ms to look at `stop`, so a signal handler can end it. Once `stop` is set it
    // still delivers the datagrams it holds (due within 1 s), reading nothing new, then returns.
    void run(const std::atomic<bool>& stop, std::uint64_t deadline_us = 0);

    // One round: sends what is due, waits up to max_wait_us for traffic or the next delivery,
    // reads what arrived.
    void step(std::uint64_t max_wait_us);

private:
    struct Client {
        UdpAddress address;
        int upstream_fd = -1;
        transport::LinkModel up, down;
        std::optional<transport::PeerId> slot;  // from config.client_slots
        std::uint64_t last_active_us = 0;
    };
    struct Pending {
        std::uint64_t due_us;
        std::uint64_t sequence;
        std::uint32_t client;
        bool to_server;
        std::vector<std::uint8_t> bytes;
    };
    struct Later {
        bool operator()(const Pending& a, const Pending& b) const {
            return a.due_us != b.due_us ? a.due_us > b.due_us : a.sequence > b.sequence;
        }
    };

    void read_clients();
    void read_server(std::uint32_t id, Client& client);
    void impair(std::uint32_t id, bool to_server, const std::uint8_t* data, std::size_t size, std::uint64_t now);
    void deliver_due(std::uint64_t now);
    void forget_idle(std::uint64_t now);
    // Whether a datagram between this client and the server at `now` crosses an active cut.
    bool is_cut(const Client& client, std::uint64_t now) const;
    // The client id for a source address, adding it if there is room; nullopt when full.
    std::optional<std::uint32_t> find_or_add_client(const UdpAddress& from, std::uint64_t now);

    UdpProxyConfig config_;
    int listen_fd_ = -1;
    std::uint16_t port_ = 0;
    std::map<std::uint32_t, Client> clients_;
    std::map<std::string, std::uint32_t> client_ids_;  // UdpAddress::key() -> id
    std::map<std::string, transport::PeerId> client_slots_;  // UdpAddress::key() -> slot
    std::uint32_t next_client_ = 0;
    std::priority_queue<Pending, std::vector<Pending>, Later> queue_;
    std::size_t queued_bytes_ = 0;
    std::uint64_t next_sequence_ = 0;
    std::uint64_t next_idle_check_us_ = 0;
    std::vector<std::uint8_t> buffer_;
    UdpProxyCounters counters_;
};

}  // namespace lockroll::net
