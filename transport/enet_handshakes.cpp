#include "transport/enet_handshakes.h"

#include <enet/enet.h>

#include <cstring>

#include "transport/enet_datagram.h"

namespace lockroll::transport {

namespace {
void handshake_timeout(ENetPeer* peer) { enet_peer_timeout(peer, ENET_PEER_TIMEOUT_LIMIT, kHandshakeTimeoutMs, kHandshakeTimeoutMs); }
}  // namespace

std::size_t prepare_for_connect(ENetHost* host) {
    EnetDatagram d;
    if (host->receivedData == nullptr || !read_enet_datagram({host->receivedData, host->receivedDataLength}, host->checksum != nullptr, d))
        return 0;
    // ENet reads a datagram without a peer id only for its first command, a connect.
    if (d.peer_id != ENET_PROTOCOL_MAXIMUM_PEER_ID || d.commands.size() < sizeof(ENetProtocolConnect) ||
        (d.commands[0] & ENET_PROTOCOL_COMMAND_MASK) != ENET_PROTOCOL_COMMAND_CONNECT)
        return 0;
    const std::uint8_t* connect = d.commands.data();
    enet_uint32 connect_id = 0;  // as it came off the wire, as ENet keeps it
    std::memcpy(&connect_id, connect + offsetof(ENetProtocolConnect, connectID), sizeof connect_id);
    const std::uint16_t client_slot = enet_read_be16(connect + offsetof(ENetProtocolConnect, outgoingPeerID));
    const ENetAddress& from = host->receivedAddress;
    std::size_t reset = 0;
    ENetPeer* free_slot = nullptr;
    for (std::size_t i = 0; i < host->peerCount; ++i) {
        ENetPeer* p = &host->peers[i];
        if (p->state == ENET_PEER_STATE_ACKNOWLEDGING_CONNECT && p->address.host == from.host && p->address.port == from.port &&
            p->outgoingPeerID == client_slot && p->connectID != connect_id) {
            enet_peer_reset(p);  // the client reset the slot it came from: it will never acknowledge
            ++reset;
        }
        if (p->state == ENET_PEER_STATE_DISCONNECTED && free_slot == nullptr) free_slot = p;
    }
    // ENet takes the first free slot (enet_protocol_handle_connect); when it refuses the connect
    // the slot stays free with the timeout it should have anyway.
    if (free_slot != nullptr) handshake_timeout(free_slot);
    return reset;
}

}  // namespace lockroll::transport
