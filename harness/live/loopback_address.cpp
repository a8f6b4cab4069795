#include "harness/live/loopback_address.h"

#include <cstdlib>

#include "harness/match/cli_error.h"
#include "net/udp_address.h"

namespace lockroll::harness {

std::string Endpoint::text() const {
    return (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

Endpoint parse_loopback_endpoint(const std::string& text, const std::string& flag, bool allow_port_zero) {
    std::string error;
    const auto a = net::parse_udp_address(text, &error);
    if (!a) throw UsageError(flag + " " + text + ": " + error);
    if (!a->is_loopback()) throw UsageError(flag + " " + text + ": only loopback addresses (127.0.0.0/8 or ::1) are allowed");
    if (a->port() == 0 && !allow_port_zero) throw UsageError(flag + " " + text + ": port must be 1..65535");
    Endpoint e;
    e.port = a->port();
    // to_string() is "HOST:PORT" or "[V6]:PORT": the numeric host ENet wants.
    const std::string s = a->to_string();
    e.host = s.substr(0, s.rfind(':'));
    if (!e.host.empty() && e.host.front() == '[') e.host = e.host.substr(1, e.host.size() - 2);
    return e;
}

SlotAddress parse_slot_address(const std::string& text, const std::string& flag, const std::string& shape) {
    const auto eq = text.find('=');
    char* end = nullptr;
    const std::string slot_text = text.substr(0, eq == std::string::npos ? 0 : eq);
    const long slot = std::strtol(slot_text.c_str(), &end, 10);
    if (eq == std::string::npos || slot_text.empty() || *end != '\0') throw UsageError(flag + " " + text + ": expected " + shape);
    return {slot, text.substr(eq + 1)};
}

}  // namespace lockroll::harness
