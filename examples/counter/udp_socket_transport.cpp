#include "udp_socket_transport.h"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace example {

namespace {
constexpr std::size_t kIdBytes = 4;

bool same(const sockaddr_in& a, const sockaddr_in& b) {
    return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
}
}  // namespace

UdpSocketTransport::UdpSocketTransport(lockroll::transport::PeerId local_id, std::uint16_t port, lockroll::transport::PeerId max_peers)
    : local_id_(local_id), peers_(max_peers), buffer_(kIdBytes + lockroll::transport::kMaxDatagramBytes + 1) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
        const std::string why = std::strerror(errno);
        if (fd_ >= 0) ::close(fd_);
        throw std::runtime_error("UdpSocketTransport: cannot bind 127.0.0.1:" + std::to_string(port) + ": " + why);
    }
    socklen_t len = sizeof a;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
}

UdpSocketTransport::~UdpSocketTransport() { ::close(fd_); }

void UdpSocketTransport::bind_peer(lockroll::transport::PeerId id, const sockaddr_in& address) {
    peers_[id] = address;
    events_.push_back({lockroll::transport::TransportEvent::Type::Connected, id, {}});
}

bool UdpSocketTransport::connect(lockroll::transport::PeerId remote, const std::string& host, std::uint16_t port, std::string* error) {
    const auto refuse = [&](const std::string& why) {
        if (error) *error = why;
        return false;
    };
    if (remote >= peers_.size() || remote == local_id_) return refuse("peer id out of range or our own");
    if (peers_[remote]) return refuse("already known");
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) return refuse("host " + host + " is not a numeric IPv4 address");
    bind_peer(remote, a);
    return true;
}

bool UdpSocketTransport::is_connected(lockroll::transport::PeerId remote) const { return remote < peers_.size() && peers_[remote]; }

bool UdpSocketTransport::send(lockroll::transport::PeerId to, std::span<const std::uint8_t> bytes, lockroll::transport::Micros) {
    if (!is_connected(to) || bytes.size() > lockroll::transport::kMaxDatagramBytes) {
        ++counters_.rejected;
        return false;
    }
    for (std::size_t i = 0; i < kIdBytes; ++i) buffer_[i] = static_cast<std::uint8_t>(local_id_ >> (8 * i));
    std::memcpy(buffer_.data() + kIdBytes, bytes.data(), bytes.size());
    const sockaddr_in& a = *peers_[to];
    ++counters_.datagrams_sent;
    counters_.bytes_sent += bytes.size();
    if (::sendto(fd_, buffer_.data(), kIdBytes + bytes.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a) < 0)
        ++counters_.dropped;  // a full socket buffer or an ICMP error: lost, as UDP may
    return true;
}

bool UdpSocketTransport::receive(lockroll::transport::Datagram& out, lockroll::transport::Micros now) {
    for (;;) {
        sockaddr_in from{};
        socklen_t len = sizeof from;
        const ssize_t n =
            ::recvfrom(fd_, buffer_.data(), buffer_.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
        if (n < 0) return false;  // EAGAIN: nothing more now (errors: the same, tried again next call)
        const auto size = static_cast<std::size_t>(n);
        if (size < kIdBytes || size > kIdBytes + lockroll::transport::kMaxDatagramBytes) {
            ++counters_.rejected;
            continue;
        }
        lockroll::transport::PeerId id = 0;
        for (std::size_t i = 0; i < kIdBytes; ++i) id |= lockroll::transport::PeerId{buffer_[i]} << (8 * i);
        if (id >= peers_.size() || id == local_id_ || (peers_[id] && !same(*peers_[id], from))) {
            ++counters_.rejected;
            continue;
        }
        if (!peers_[id]) bind_peer(id, from);
        out.from = id;
        out.time_us = now;
        out.reliable = false;
        out.bytes.assign(buffer_.begin() + kIdBytes, buffer_.begin() + static_cast<std::ptrdiff_t>(size));
        ++counters_.datagrams_received;
        counters_.bytes_received += out.bytes.size();
        return true;
    }
}

bool UdpSocketTransport::next_event(lockroll::transport::TransportEvent& out) {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

}  // namespace example
