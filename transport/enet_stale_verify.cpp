#include "transport/enet_stale_verify.h"

#include <enet/enet.h>

#include <cstring>

#include "transport/enet_datagram.h"

namespace lockroll::transport {

bool is_stale_verify_connect(const ENetHost* host) {
    EnetDatagram d;
    if (host->receivedData == nullptr || !read_enet_datagram({host->receivedData, host->receivedDataLength}, host->checksum != nullptr, d))
        return false;
    // ENet's routing of a datagram to a slot (enet_protocol_handle_incoming_commands): the header's
    // peer id, from the slot's address. A connecting slot checks no session id.
    if (d.peer_id >= host->peerCount) return false;
    const ENetPeer& peer = host->peers[d.peer_id];
    if (peer.state != ENET_PEER_STATE_CONNECTING) return false;
    if (peer.address.host != host->receivedAddress.host || peer.address.port != host->receivedAddress.port) return false;
    // Only the first verify counts: once one is taken, the slot is no longer connecting.
    const std::uint8_t* verify = find_enet_command(d.commands, ENET_PROTOCOL_COMMAND_VERIFY_CONNECT);
    if (verify == nullptr) return false;
    // ENet compares the connect id as it came off the wire: so do we.
    enet_uint32 connect_id = 0;
    std::memcpy(&connect_id, verify + offsetof(ENetProtocolVerifyConnect, connectID), sizeof connect_id);
    return connect_id != peer.connectID;
}

}  // namespace lockroll::transport
