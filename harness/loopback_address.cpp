#include "harness/loopback_address.h"

#include <arpa/inet.h>

#include <cstdlib>

#include "harness/cli_error.h"

namespace lockroll::harness {

std::string Endpoint::text() const {
    return (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

Endpoint parse_loopback_endpoint(const std::string& text, const std::string& flag, bool allow_port_zero) {
    const auto fail = [&](const std::string& why) -> Endpoint { throw UsageError(flag + " " + text + ": " + why); };
    Endpoint e;
    std::string port;
    if (!text.empty() && text.front() == '[') {
        const auto close = text.find(']');
        if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':')
            return fail("expected [::1]:PORT");
        e.host = text.substr(1, close - 1);
        port = text.substr(close + 2);
    } else {
        const auto colon = text.rfind(':');
        if (colon == std::string::npos) return fail("expected HOST:PORT");
        e.host = text.substr(0, colon);
        port = text.substr(colon + 1);
    }
    in_addr v4{};
    in6_addr v6{};
    if (inet_pton(AF_INET, e.host.c_str(), &v4) == 1) {
        if ((ntohl(v4.s_addr) >> 24) != 127) return fail("only loopback addresses (127.0.0.0/8 or ::1) are allowed");
    } else if (inet_pton(AF_INET6, e.host.c_str(), &v6) == 1) {
        if (!IN6_IS_ADDR_LOOPBACK(&v6)) return fail("only loopback addresses (127.0.0.0/8 or ::1) are allowed");
    } else {
        return fail("expected a numeric loopback address (127.0.0.0/8 or ::1)");
    }
    char* end = nullptr;
    const long v = std::strtol(port.c_str(), &end, 10);
    if (port.empty() || *end != '\0' || v < (allow_port_zero ? 0 : 1) || v > 65535)
        return fail(allow_port_zero ? "port must be 0..65535" : "port must be 1..65535");
    e.port = static_cast<std::uint16_t>(v);
    return e;
}

}  // namespace lockroll::harness
