// A UDP endpoint address (IPv4 or IPv6) parsed from text, and the loopback rule: lockroll's
// real-network tools only ever talk to 127.0.0.0/8 and ::1, so commands check is_loopback()
// before binding or sending anything.
//
// Contract: parsing takes numeric addresses only ("127.0.0.1", "::1", "[::1]:9000") plus the
// name "localhost" (= 127.0.0.1); it never consults DNS. Errors come back as a message naming
// the text, never as an exception.
#pragma once

#include <sys/socket.h>

#include <cstdint>
#include <optional>
#include <string>

namespace lockroll::net {

struct UdpAddress {
    sockaddr_storage storage{};
    socklen_t length = 0;

    int family() const { return storage.ss_family; }
    std::uint16_t port() const;
    bool is_loopback() const;       // 127.0.0.0/8 or ::1
    std::string to_string() const;
    UdpAddress with_port(std::uint16_t port) const;  // "127.0.0.1:9000" or "[::1]:9000"
    const sockaddr* sockaddr_ptr() const { return reinterpret_cast<const sockaddr*>(&storage); }
    // Family, port and address bytes: equal keys <=> same endpoint.
    std::string key() const;
};

// host + port; nullopt with *error set when the host is not a numeric address or "localhost".
std::optional<UdpAddress> make_udp_address(const std::string& host, std::uint16_t port, std::string* error);

// "HOST:PORT", "[V6]:PORT", or (when default_host is given) a bare "PORT".
std::optional<UdpAddress> parse_udp_address(const std::string& text, std::string* error,
                                            const std::string& default_host = "");

// From what recvfrom() filled in.
UdpAddress udp_address_from(const sockaddr_storage& storage, socklen_t length);

}  // namespace lockroll::net
