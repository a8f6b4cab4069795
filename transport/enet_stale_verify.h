// The client side of issue 20: a VERIFY_CONNECT answering an older connect from one of our
// ENet slots must not end the connect that slot has pending now.
//
// ENet names a client's connection by its slot: the server's answer to a connect (VERIFY_CONNECT)
// goes to the slot index the connect came from, and ENet takes it for whatever connect that slot
// has pending. When a connect is given up (timed out or reset) and the slot connects again, the
// server may still be answering the old one (it resends its verify until its own handshake timeout);
// ENet then finds the old verify's connect id is not its pending connect's and gives the pending
// connect up (the slot becomes a zombie: a disconnect). A client redialling a server that still
// holds its abandoned handshakes could lose every connect that way (the relay's lockout, issue 20).
// Such a datagram is to be ignored instead: it belongs to a connection that no longer exists.
#pragma once

struct _ENetHost;

namespace lockroll::transport {

// True when the datagram `host` just received (ENetHost::receivedData, receivedDataLength,
// receivedAddress: what an intercept callback sees) is addressed to a slot of `host` still
// connecting, from the address that slot connects to, and its first VERIFY_CONNECT carries a
// connect id other than that slot's connect's. False for anything else, including every
// datagram that cannot be read whole as ENet would read it (ENet then decides, as before).
bool is_stale_verify_connect(const _ENetHost* host);

}  // namespace lockroll::transport
