// Reading a raw ENet datagram as ENet's own receive path does (protocol.c, 1.3.x), bounds-checked
// at every step, for ENetHost::intercept callbacks: they see each datagram before ENet parses it.
// Nothing here trusts a length the datagram states without checking it against its size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace lockroll::transport {

struct EnetDatagram {
    std::uint16_t peer_id = 0;                 // the header's peer id (0xFFF: no peer, a connect)
    std::span<const std::uint8_t> commands;    // the bytes after the header
};

// The header of datagram `d` (with the 4-byte checksum ENet adds when the host has one).
// False when it cannot be read here: shorter than its header, or compressed (ENet decompresses
// it first; lockroll's hosts have no compressor and ENet drops such datagrams itself).
bool read_enet_datagram(std::span<const std::uint8_t> d, bool checksum, EnetDatagram& out);

// The first command numbered `command` (ENET_PROTOCOL_COMMAND_*) in `commands`, its fixed part
// whole, found by walking the commands as ENet does (each command's size, plus the payload of
// the send commands). nullptr when the walk ends first: at the end of the datagram, or where
// ENet would stop reading it (an unknown command, a command or payload cut short).
const std::uint8_t* find_enet_command(std::span<const std::uint8_t> commands, std::uint8_t command);

// The payload a command carries after its fixed part (the send commands' dataLength; 0 for the
// others). `command` must hold the command's whole fixed part.
std::size_t enet_command_payload(const std::uint8_t* command);

// Big-endian 16-bit field (ENet's wire order for its lengths and ids).
inline std::uint16_t enet_read_be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

}  // namespace lockroll::transport
