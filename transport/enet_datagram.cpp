#include "transport/enet_datagram.h"

#include <enet/enet.h>

namespace lockroll::transport {

bool read_enet_datagram(std::span<const std::uint8_t> d, bool checksum, EnetDatagram& out) {
    if (d.size() < 2) return false;
    const std::uint16_t header = enet_read_be16(d.data());
    if ((header & ENET_PROTOCOL_HEADER_FLAG_COMPRESSED) != 0) return false;
    std::size_t size = (header & ENET_PROTOCOL_HEADER_FLAG_SENT_TIME) != 0 ? sizeof(ENetProtocolHeader) : offsetof(ENetProtocolHeader, sentTime);
    if (checksum) size += sizeof(enet_uint32);
    if (d.size() < size) return false;
    out.peer_id = static_cast<std::uint16_t>(header & ~(ENET_PROTOCOL_HEADER_FLAG_MASK | ENET_PROTOCOL_HEADER_SESSION_MASK));
    out.commands = d.subspan(size);
    return true;
}

std::size_t enet_command_payload(const std::uint8_t* c) {
    switch (c[0] & ENET_PROTOCOL_COMMAND_MASK) {
        case ENET_PROTOCOL_COMMAND_SEND_RELIABLE: return enet_read_be16(c + offsetof(ENetProtocolSendReliable, dataLength));
        case ENET_PROTOCOL_COMMAND_SEND_UNRELIABLE: return enet_read_be16(c + offsetof(ENetProtocolSendUnreliable, dataLength));
        case ENET_PROTOCOL_COMMAND_SEND_UNSEQUENCED: return enet_read_be16(c + offsetof(ENetProtocolSendUnsequenced, dataLength));
        case ENET_PROTOCOL_COMMAND_SEND_FRAGMENT:
        case ENET_PROTOCOL_COMMAND_SEND_UNRELIABLE_FRAGMENT: return enet_read_be16(c + offsetof(ENetProtocolSendFragment, dataLength));
        default: return 0;
    }
}

const std::uint8_t* find_enet_command(std::span<const std::uint8_t> commands, std::uint8_t command) {
    std::size_t at = 0;
    while (commands.size() - at >= sizeof(ENetProtocolCommandHeader)) {
        const std::uint8_t* c = commands.data() + at;
        const std::uint8_t number = c[0] & ENET_PROTOCOL_COMMAND_MASK;
        if (number == ENET_PROTOCOL_COMMAND_NONE || number >= ENET_PROTOCOL_COMMAND_COUNT) return nullptr;
        const std::size_t fixed = enet_protocol_command_size(number);
        if (fixed == 0 || commands.size() - at < fixed) return nullptr;
        if (number == command) return c;
        const std::size_t payload = enet_command_payload(c);
        if (commands.size() - at - fixed < payload) return nullptr;
        at += fixed + payload;
    }
    return nullptr;
}

}  // namespace lockroll::transport
