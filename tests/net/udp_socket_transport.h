// A transport::Transport written in the test, over plain UDP sockets (non-blocking sendto and
// recvfrom on 127.0.0.1), so a match proves the runner and the builder need nothing of ENet.
//
// Contract (transport/transport.h's, for a connectionless socket):
//  - Wire: each datagram is the sender's peer id (u32, little-endian) and the payload, at most
//    kMaxDatagramBytes. No handshake, no reliability: send_reliable() is send(), and the
//    session re-requests what is lost.
//  - Connections: connect(id, host, port) learns where `id` listens (host: a numeric IPv4
//    address) and reports it Connected at once. The other side learns the sender from its first
//    datagram: the id it carries is bound to the address it came from (Connected), and from
//    then on that id is taken only from that address. A datagram claiming another bound id,
//    our own id, an id out of range, or shorter than the id is dropped and counted (rejected):
//    identity comes from the address an id was first heard from.
//  - Never blocks, never reads a clock (arrivals are stamped with receive()'s `now`), never
//    throws on traffic; memory is bounded (one address per id, one event per id).
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "transport/transport.h"

namespace lockroll::test {

class UdpSocketTransport final : public transport::Transport {
public:
    // Binds 127.0.0.1:port (0: one the kernel picks, see port()); ids 0..max_peers-1. Throws
    // std::runtime_error naming the port when the socket cannot be bound.
    UdpSocketTransport(transport::PeerId local_id, std::uint16_t port, transport::PeerId max_peers);
    ~UdpSocketTransport() override;
    UdpSocketTransport(const UdpSocketTransport&) = delete;
    UdpSocketTransport& operator=(const UdpSocketTransport&) = delete;

    std::uint16_t port() const { return port_; }
    transport::PeerId local_id() const override { return local_id_; }
    bool send(transport::PeerId to, std::span<const std::uint8_t> bytes, transport::Micros now) override;
    bool receive(transport::Datagram& out, transport::Micros now) override;
    const transport::TransportCounters& counters() const override { return counters_; }
    bool next_event(transport::TransportEvent& out) override;
    bool connect(transport::PeerId remote, const std::string& host, std::uint16_t port, std::string* error = nullptr) override;
    bool is_connected(transport::PeerId remote) const override;

private:
    void bind_peer(transport::PeerId id, const sockaddr_in& address);

    int fd_ = -1;
    std::uint16_t port_ = 0;
    transport::PeerId local_id_;
    std::vector<std::optional<sockaddr_in>> peers_;  // by id: where it is, once known
    std::deque<transport::TransportEvent> events_;
    transport::TransportCounters counters_;
    std::vector<std::uint8_t> buffer_;
};

}  // namespace lockroll::test
