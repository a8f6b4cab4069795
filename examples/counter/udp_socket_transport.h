// A game's own lockroll::transport::Transport, over plain UDP sockets (non-blocking sendto and
// recvfrom on 127.0.0.1): `counter ... udp` plays over it, built only against the installed
// package, and tests/net plays and unit-tests it too, so a match proves the runner and the
// builder need nothing of ENet.
//
// Contract (<lockroll/transport/transport.h>'s, for a connectionless socket):
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

#include <lockroll/transport/transport.h>

namespace example {

class UdpSocketTransport final : public lockroll::transport::Transport {
public:
    // Binds 127.0.0.1:port (0: one the kernel picks, see port()); ids 0..max_peers-1. Throws
    // std::runtime_error naming the port when the socket cannot be bound.
    UdpSocketTransport(lockroll::transport::PeerId local_id, std::uint16_t port, lockroll::transport::PeerId max_peers);
    ~UdpSocketTransport() override;
    UdpSocketTransport(const UdpSocketTransport&) = delete;
    UdpSocketTransport& operator=(const UdpSocketTransport&) = delete;

    std::uint16_t port() const { return port_; }
    lockroll::transport::PeerId local_id() const override { return local_id_; }
    bool send(lockroll::transport::PeerId to, std::span<const std::uint8_t> bytes, lockroll::transport::Micros now) override;
    bool receive(lockroll::transport::Datagram& out, lockroll::transport::Micros now) override;
    const lockroll::transport::TransportCounters& counters() const override { return counters_; }
    bool next_event(lockroll::transport::TransportEvent& out) override;
    bool connect(lockroll::transport::PeerId remote, const std::string& host, std::uint16_t port, std::string* error = nullptr) override;
    bool is_connected(lockroll::transport::PeerId remote) const override;

private:
    void bind_peer(lockroll::transport::PeerId id, const sockaddr_in& address);

    int fd_ = -1;
    std::uint16_t port_ = 0;
    lockroll::transport::PeerId local_id_;
    std::vector<std::optional<sockaddr_in>> peers_;  // by id: where it is, once known
    std::deque<lockroll::transport::TransportEvent> events_;
    lockroll::transport::TransportCounters counters_;
    std::vector<std::uint8_t> buffer_;
};

}  // namespace example
