// HOST:PORT flags of the real-process commands (peer, live), restricted to loopback: lockroll's
// networked runs are experiments on one machine and must never send traffic anywhere else.
//
// Parsing is net/udp_address.h (numeric addresses or "localhost", never DNS); accepted are
// 127.0.0.0/8 and ::1 written [::1]:PORT; PORT 0..65535
// (0 only where the caller allows an ephemeral port). Anything else is a UsageError naming the
// flag and the text.
#pragma once

#include <cstdint>
#include <string>

namespace lockroll::harness {

struct Endpoint {
    std::string host;  // as given, without brackets
    std::uint16_t port = 0;
    std::string text() const;  // HOST:PORT, brackets for IPv6
};

Endpoint parse_loopback_endpoint(const std::string& text, const std::string& flag, bool allow_port_zero);

// SLOT=ADDRESS flags (`peer --peer`, `proxy --client-slot`): the slot, a decimal integer (its
// range is the caller's to check), and the text after '='. Anything else is a UsageError
// "<flag> <text>: expected <shape>".
struct SlotAddress {
    long slot = 0;
    std::string address;
};
SlotAddress parse_slot_address(const std::string& text, const std::string& flag, const std::string& shape);

}  // namespace lockroll::harness
