#include "net/udp_address.h"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <charconv>
#include <cstdio>
#include <cstring>

namespace lockroll::net {

std::uint16_t UdpAddress::port() const {
    if (family() == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in*>(&storage)->sin_port);
    if (family() == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6*>(&storage)->sin6_port);
    return 0;
}

bool UdpAddress::is_loopback() const {
    if (family() == AF_INET)
        return (ntohl(reinterpret_cast<const sockaddr_in*>(&storage)->sin_addr.s_addr) >> 24) == 127;
    if (family() == AF_INET6) {
        const in6_addr& a = reinterpret_cast<const sockaddr_in6*>(&storage)->sin6_addr;
        return IN6_IS_ADDR_LOOPBACK(&a);
    }
    return false;
}

std::string UdpAddress::to_string() const {
    char buf[INET6_ADDRSTRLEN] = {};
    if (family() == AF_INET) {
        inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(&storage)->sin_addr, buf, sizeof buf);
        return std::string(buf) + ":" + std::to_string(port());
    }
    if (family() == AF_INET6) {
        inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(&storage)->sin6_addr, buf, sizeof buf);
        char out[INET6_ADDRSTRLEN + 8] = {};
        std::snprintf(out, sizeof out, "[%s]:%u", buf, static_cast<unsigned>(port()));
        return out;
    }
    return "(no address)";
}

UdpAddress UdpAddress::with_port(std::uint16_t p) const {
    UdpAddress a = *this;
    if (family() == AF_INET) reinterpret_cast<sockaddr_in*>(&a.storage)->sin_port = htons(p);
    if (family() == AF_INET6) reinterpret_cast<sockaddr_in6*>(&a.storage)->sin6_port = htons(p);
    return a;
}

std::string UdpAddress::key() const {
    // family, port (2 bytes), then the 4- or 16-byte address.
    char k[19] = {};
    std::size_t n = 3;
    const std::uint16_t p = port();
    k[0] = static_cast<char>(family());
    k[1] = static_cast<char>(p & 0xFF);
    k[2] = static_cast<char>(p >> 8);
    if (family() == AF_INET) {
        std::memcpy(k + 3, &reinterpret_cast<const sockaddr_in*>(&storage)->sin_addr, 4);
        n += 4;
    } else if (family() == AF_INET6) {
        std::memcpy(k + 3, &reinterpret_cast<const sockaddr_in6*>(&storage)->sin6_addr, 16);
        n += 16;
    }
    return std::string(k, n);
}

std::optional<UdpAddress> make_udp_address(const std::string& host_in, std::uint16_t port, std::string* error) {
    const std::string host = host_in == "localhost" ? "127.0.0.1" : host_in;
    UdpAddress a;
    auto* v4 = reinterpret_cast<sockaddr_in*>(&a.storage);
    auto* v6 = reinterpret_cast<sockaddr_in6*>(&a.storage);
    if (inet_pton(AF_INET, host.c_str(), &v4->sin_addr) == 1) {
        v4->sin_family = AF_INET;
        v4->sin_port = htons(port);
        a.length = sizeof(sockaddr_in);
        return a;
    }
    if (inet_pton(AF_INET6, host.c_str(), &v6->sin6_addr) == 1) {
        v6->sin6_family = AF_INET6;
        v6->sin6_port = htons(port);
        a.length = sizeof(sockaddr_in6);
        return a;
    }
    if (error) *error = "'" + host_in + "' is not a numeric IPv4/IPv6 address or localhost";
    return std::nullopt;
}

std::optional<UdpAddress> parse_udp_address(const std::string& text, std::string* error,
                                            const std::string& default_host) {
    const auto fail = [&](const std::string& why) -> std::optional<UdpAddress> {
        if (error) *error = "'" + text + "': " + why;
        return std::nullopt;
    };
    std::string host = default_host;
    std::string port_text = text;
    if (!text.empty() && text.front() == '[') {
        const auto close = text.find(']');
        if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':')
            return fail("expected [IPV6]:PORT");
        host = text.substr(1, close - 1);
        port_text = text.substr(close + 2);
    } else if (const auto colon = text.rfind(':'); colon != std::string::npos) {
        if (text.find(':') != colon) return fail("write IPv6 addresses as [ADDRESS]:PORT");
        host = text.substr(0, colon);
        port_text = text.substr(colon + 1);
    } else if (default_host.empty()) {
        return fail("expected HOST:PORT");
    }
    unsigned port = 0;
    const char* end = port_text.data() + port_text.size();
    const auto [ptr, ec] = std::from_chars(port_text.data(), end, port);
    if (port_text.empty() || ec != std::errc() || ptr != end || port > 65535)
        return fail("port must be a number in 0..65535");
    std::string why;
    auto a = make_udp_address(host, static_cast<std::uint16_t>(port), &why);
    if (!a) return fail(why);
    return a;
}

UdpAddress udp_address_from(const sockaddr_storage& storage, socklen_t length) {
    UdpAddress a;
    a.storage = storage;
    a.length = length;
    return a;
}

}  // namespace lockroll::net
