// Per-datagram header bytes for turning payload counts into wire bandwidth (derivation and
// sources in docs/network-model.md). Transports count payload only; reports add these.
#pragma once

#include <cstdint>

namespace lockroll::transport {

inline constexpr std::uint32_t kIpv4HeaderBytes = 20;  // without options
inline constexpr std::uint32_t kUdpHeaderBytes = 8;
inline constexpr std::uint32_t kUdpIpv4HeaderBytes = kIpv4HeaderBytes + kUdpHeaderBytes;  // 28

// ENet 1.3: ENetProtocolHeader without its optional sentTime (only peerID, 2 bytes: a datagram
// that carries nothing needing acknowledgement omits sentTime), plus one
// ENetProtocolSendUnsequenced command header (4-byte ENetProtocolCommandHeader +
// unsequencedGroup + dataLength = 8 bytes). No checksum (ENetHost::checksum unset).
inline constexpr std::uint32_t kEnetProtocolHeaderBytes = 2;
inline constexpr std::uint32_t kEnetSendUnsequencedBytes = 8;
inline constexpr std::uint32_t kEnetHeaderBytes = kEnetProtocolHeaderBytes + kEnetSendUnsequencedBytes;  // 10
inline constexpr std::uint32_t kEnetUdpIpv4HeaderBytes = kEnetHeaderBytes + kUdpIpv4HeaderBytes;     // 38

// Bytes on the wire (IP layer and up) for `datagrams` datagrams carrying `payload` bytes.
constexpr std::uint64_t wire_bytes(std::uint64_t payload, std::uint64_t datagrams, std::uint32_t per_datagram) {
    return payload + datagrams * per_datagram;
}

}  // namespace lockroll::transport
