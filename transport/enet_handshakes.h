// The accepting side's handshakes (EnetServer): how long a half-open connection may hold a slot,
// and the rule that ends one its client gave up (issue 20).
//
// A client's connect makes ENet take a free slot in ACKNOWLEDGING_CONNECT and resend its answer
// (VERIFY_CONNECT) until the client acknowledges it. Left to ENet:
//  - a client that never acknowledges holds the slot, and a place in the address's
//    duplicatePeers count, for ENet's default timeout, 30 s: a client that gave its connect up
//    and connects again from the same slot leaves one such handshake behind per attempt, and a
//    few dozen lock its IP out (max_connections_per_address);
//  - the old handshake's resent verify reaches the client's slot, which ENet (unpatched) takes
//    for its new connect and gives that up too (transport/enet_stale_verify.h is the client's cure).
// So a connect from the address and client slot (the connect's outgoingPeerID) of a handshake
// still in ACKNOWLEDGING_CONNECT with another connect id ends that handshake (an ENet client slot
// holds one connection: its client reset it), and a handshake gives up after
// kHandshakeTimeoutMs. Established connections keep their own timeouts (EnetServerConfig).
#pragma once

#include <cstddef>
#include <cstdint>

struct _ENetHost;

namespace lockroll::transport {

// How long the server resends its answer to a connect that is not acknowledged before it drops
// the half-open connection (ENet's timeoutMaximum for a slot until it is established; ENet's own
// is 30 s). ENet resends after 0.5, 1.5 and 3.5 s: four answers, as a client's own connect
// (EnetConfig::timeout_max_ms, 5 s) tries, and a lost handshake is one the client retries.
constexpr std::uint32_t kHandshakeTimeoutMs = 5'000;

// For an intercept callback (ENetHost::intercept), before ENet handles the datagram `host` just
// received: when it is a connect (no peer id, first command CONNECT), resets every slot still
// in ACKNOWLEDGING_CONNECT from the same address and client slot whose connect id differs (no
// event: it never had one), and gives the slot ENet will take for the connect (the first free
// one) the handshake timeout. Returns the number of slots reset. Anything else is left alone.
std::size_t prepare_for_connect(_ENetHost* host);

}  // namespace lockroll::transport
