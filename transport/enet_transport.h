// The Transport interface over real UDP, through ENet: one ENet host per local peer, one ENet
// connection per remote peer, input datagrams on channel 0 as unreliable *unsequenced* packets
// (no ordering, no retransmission, no head-of-line blocking: the session resends inputs itself).
//
// ENet keeps its own millisecond clock for its protocol (handshake, pings, timeouts): that is
// ENet's business. This wrapper takes `now` only to stamp received datagrams and never makes a
// decision from the wall clock; it never blocks either (every ENet service call has timeout 0).
//
// Peer ids travel in ENet's connect data: the side that calls connect() sends its local id, and
// the accepting side learns the remote id from it. Exactly one side of each pair connects (by
// convention the lower id). A connection claiming an id that is already taken, or our own, is
// refused and counted as rejected; so is traffic from peers without an established connection.
// ENet itself discards duplicate unsequenced packets (its unsequenced window).
//
// Not thread-safe; one EnetTransport per thread. Not copyable or movable.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "transport/transport.h"

struct _ENetHost;
struct _ENetPeer;
struct _ENetEvent;

namespace lockroll::transport {

struct EnetConfig {
    PeerId local_id = 0;
    std::string bind_host = "127.0.0.1";  // address to listen on ("0.0.0.0" for every interface)
    std::uint16_t port = 0;               // 0: an ephemeral port chosen by the OS (see port())
    std::size_t max_peers = 16;           // ENet connection slots, incoming and outgoing
};

class EnetTransport final : public Transport {
public:
    // Throws std::runtime_error naming host:port when ENet cannot initialise or bind.
    explicit EnetTransport(const EnetConfig& config);
    ~EnetTransport() override;
    EnetTransport(const EnetTransport&) = delete;
    EnetTransport& operator=(const EnetTransport&) = delete;

    // The UDP port actually bound (the ephemeral one when config.port was 0).
    std::uint16_t port() const { return port_; }

    // Starts connecting to the peer `remote` listening at host:port. Returns false, with a
    // reason in *error if given, when the id is ours or already known, the host does not
    // resolve, or no connection slot is free. The connection completes during later poll() or
    // receive() calls; is_connected() tells when.
    bool connect(PeerId remote, const std::string& host, std::uint16_t port, std::string* error = nullptr);
    bool is_connected(PeerId remote) const;
    std::vector<PeerId> connected_peers() const;

    // Lets ENet send and receive without blocking: completes handshakes, answers pings, queues
    // arrived datagrams (stamped with `now`). receive() calls it when its queue is empty.
    void poll(Micros now);

    PeerId local_id() const override { return local_id_; }
    // Sends at once (flushes the host), so one send is one UDP datagram.
    bool send(PeerId to, std::span<const std::uint8_t> bytes, Micros now) override;
    bool receive(Datagram& out, Micros now) override;
    const TransportCounters& counters() const override { return counters_; }

    // UDP payload bytes this host sent / received: our datagrams plus ENet's own headers,
    // handshakes, acknowledgements and pings (ENetHost::totalSentData / totalReceivedData).
    // Add kUdpIpv4HeaderBytes per datagram for IP-level figures.
    std::uint64_t wire_bytes_sent() const;
    std::uint64_t wire_bytes_received() const;

    // ENet service errors (socket failures) seen by poll(); the transport keeps going.
    std::uint64_t service_errors() const { return service_errors_; }

private:
    struct Connection {
        _ENetPeer* peer = nullptr;
        bool established = false;
    };

    void handle(const _ENetEvent& event, Micros now);
    void forget(_ENetPeer* peer);

    PeerId local_id_;
    _ENetHost* host_ = nullptr;
    std::uint16_t port_ = 0;
    std::map<PeerId, Connection> by_id_;
    std::unordered_map<_ENetPeer*, PeerId> by_peer_;
    std::deque<Datagram> inbox_;
    TransportCounters counters_;
    std::uint64_t service_errors_ = 0;
};

}  // namespace lockroll::transport
