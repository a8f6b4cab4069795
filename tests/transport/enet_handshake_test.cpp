// Handshakes a client gave up (issue 20), on both sides:
//  - the client's: a VERIFY_CONNECT answering an older connect of one of its slots is ignored
//    (transport/enet_stale_verify.h), read from crafted datagrams, and over real UDP with an
//    EnetTransport dialling a fake server that answers with a stale verify first;
//  - the server's (one ENet host, no demux): a connect from a handshake's address and client
//    slot resets that handshake, and a handshake nobody acknowledges gives up after
//    kHandshakeTimeoutMs, not ENet's 30 s (transport/enet_handshakes.h).
// Real sockets on 127.0.0.1 only; every wait is bounded and the outcomes are asserted, not times.
#include <enet/enet.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <vector>

#include "transport/enet_datagram.h"
#include "transport/enet_handshakes.h"
#include "transport/enet_library.h"
#include "transport/enet_server.h"
#include "transport/enet_stale_verify.h"
#include "transport/enet_transport.h"

using namespace lockroll::transport;

namespace {

ENetAddress loopback(std::uint16_t port) {
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = port;
    return a;
}

// ENet's answer to `connect` (its fields as the client sent them, in wire order), with
// `connect_id` (wire order), addressed to the client's slot; `sent_time` adds the 2-byte field.
std::vector<std::uint8_t> verify_for(const ENetProtocolConnect& connect, enet_uint32 connect_id, bool sent_time = false) {
    const std::uint16_t slot = ENET_NET_TO_HOST_16(connect.outgoingPeerID);
    const std::uint16_t header = static_cast<std::uint16_t>(slot | (sent_time ? ENET_PROTOCOL_HEADER_FLAG_SENT_TIME : 0));
    std::vector<std::uint8_t> d = {static_cast<std::uint8_t>(header >> 8), static_cast<std::uint8_t>(header)};
    if (sent_time) d.insert(d.end(), {0, 0});
    ENetProtocolVerifyConnect v{};
    v.header.command = static_cast<enet_uint8>(ENET_PROTOCOL_COMMAND_VERIFY_CONNECT) | static_cast<enet_uint8>(ENET_PROTOCOL_COMMAND_FLAG_ACKNOWLEDGE);
    v.header.channelID = 0xFF;
    v.header.reliableSequenceNumber = ENET_HOST_TO_NET_16(1);
    v.outgoingPeerID = ENET_HOST_TO_NET_16(0);
    v.mtu = connect.mtu;
    v.windowSize = connect.windowSize;
    v.channelCount = connect.channelCount;
    v.packetThrottleInterval = connect.packetThrottleInterval;
    v.packetThrottleAcceleration = connect.packetThrottleAcceleration;
    v.packetThrottleDeceleration = connect.packetThrottleDeceleration;
    v.connectID = connect_id;
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(&v);
    d.insert(d.end(), bytes, bytes + sizeof v);
    return d;
}

// A client host with one slot connecting to 127.0.0.1:`port` (nobody there): the stale-verify
// rule is read against it.
struct ConnectingHost {
    ENetHost* host = nullptr;
    ENetPeer* peer = nullptr;
    ENetProtocolConnect connect{};  // what its connect says (the fields the verify echoes)
    std::vector<std::uint8_t> datagram;
    explicit ConnectingHost(std::uint16_t port) {
        ensure_enet_initialized();
        host = enet_host_create(nullptr, 2, 2, 0, 0);
        const ENetAddress to = loopback(port);
        peer = enet_host_connect(host, &to, 2, 0);
        connect.outgoingPeerID = ENET_HOST_TO_NET_16(peer->incomingPeerID);
        connect.mtu = ENET_HOST_TO_NET_32(peer->mtu);
        connect.windowSize = ENET_HOST_TO_NET_32(peer->windowSize);
        connect.channelCount = ENET_HOST_TO_NET_32(2);
        connect.packetThrottleInterval = ENET_HOST_TO_NET_32(peer->packetThrottleInterval);
        connect.packetThrottleAcceleration = ENET_HOST_TO_NET_32(peer->packetThrottleAcceleration);
        connect.packetThrottleDeceleration = ENET_HOST_TO_NET_32(peer->packetThrottleDeceleration);
    }
    ~ConnectingHost() { enet_host_destroy(host); }
    // Whether the datagram `d`, received from 127.0.0.1:`from`, is a stale verify for this host.
    bool stale(std::vector<std::uint8_t> d, std::uint16_t from) {
        datagram = std::move(d);
        host->receivedData = datagram.data();
        host->receivedDataLength = datagram.size();
        host->receivedAddress = loopback(from);
        const bool r = is_stale_verify_connect(host);
        host->receivedData = nullptr;
        host->receivedDataLength = 0;
        return r;
    }
};

constexpr std::uint16_t kNobody = 9;  // a port the rule is read against, never sent to

// Plain ENet services until `done` or the bound (real time: ENet's own clock runs the protocol).
template <class Step, class Done>
bool run_until(double seconds, Step step, Done done) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < until) {
        step();
        if (done()) return true;
    }
    return false;
}

Micros micros_now() {
    return static_cast<Micros>(std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
}

// One ENet host (no fanout) of 8 slots, one of them per address: a handshake left over from an
// address keeps every other connect from it out.
EnetServerConfig one_place_per_address() {
    ensure_enet_initialized();
    EnetServerConfig config;
    config.max_connections = 8;
    config.max_connections_per_address = 1;
    return config;
}

// Serves `server` and a plain ENet `client` (then destroyed) until both saw the connection, up to
// `seconds`.
bool both_connected(EnetServer& server, ENetHost* client, double seconds) {
    bool connected = false, server_connected = false;
    run_until(
        seconds,
        [&] {
            server.poll(micros_now(), 1000);
            ServerConnectionEvent e;
            while (server.next_event(e)) server_connected = server_connected || e.type == ServerConnectionEvent::Type::Connected;
            ENetEvent ce;
            while (enet_host_service(client, &ce, 1) > 0) {
                if (ce.type == ENET_EVENT_TYPE_CONNECT) connected = true;
                if (ce.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(ce.packet);
            }
        },
        [&] { return connected && server_connected; });
    enet_host_destroy(client);
    return connected && server_connected;
}

}  // namespace

TEST(StaleVerify, OnlyAVerifyWithAnotherConnectIdForAConnectingSlotIsStale) {
    ConnectingHost c(kNobody);
    const enet_uint32 own = c.peer->connectID;
    EXPECT_FALSE(c.stale(verify_for(c.connect, own), kNobody));    // the answer to our connect
    EXPECT_TRUE(c.stale(verify_for(c.connect, own ^ 1), kNobody));  // to an older one
    EXPECT_TRUE(c.stale(verify_for(c.connect, own ^ 1, true), kNobody));
    EXPECT_FALSE(c.stale(verify_for(c.connect, own ^ 1), kNobody + 1));  // not from where we connect
    // Another slot (free), a slot the host does not have, no slot at all.
    ENetProtocolConnect other = c.connect;
    other.outgoingPeerID = ENET_HOST_TO_NET_16(1);
    EXPECT_FALSE(c.stale(verify_for(other, own ^ 1), kNobody));
    other.outgoingPeerID = ENET_HOST_TO_NET_16(4000);
    EXPECT_FALSE(c.stale(verify_for(other, own ^ 1), kNobody));
    other.outgoingPeerID = ENET_HOST_TO_NET_16(ENET_PROTOCOL_MAXIMUM_PEER_ID);
    EXPECT_FALSE(c.stale(verify_for(other, own ^ 1), kNobody));
    // A slot that is no longer connecting takes no verify at all: ENet ignores it, so do we.
    c.peer->state = ENET_PEER_STATE_CONNECTED;
    EXPECT_FALSE(c.stale(verify_for(c.connect, own ^ 1), kNobody));
    c.peer->state = ENET_PEER_STATE_CONNECTING;
}

TEST(StaleVerify, TheCommandsAreWalkedAsEnetWalksThemAndNeverPastTheDatagram) {
    ConnectingHost c(kNobody);
    const std::vector<std::uint8_t> stale = verify_for(c.connect, c.peer->connectID ^ 1);
    const auto header = [&] { return std::vector<std::uint8_t>(stale.begin(), stale.begin() + 2); };
    const std::vector<std::uint8_t> verify_command(stale.begin() + 2, stale.end());
    // Cut short anywhere: not read (ENet drops it too).
    for (std::size_t n = 0; n < stale.size(); ++n)
        EXPECT_FALSE(c.stale(std::vector<std::uint8_t>(stale.begin(), stale.begin() + static_cast<std::ptrdiff_t>(n)), kNobody)) << n;
    // Compressed: ENet reads it only after decompressing; left to ENet.
    std::vector<std::uint8_t> d = stale;
    d[0] |= ENET_PROTOCOL_HEADER_FLAG_COMPRESSED >> 8;
    EXPECT_FALSE(c.stale(d, kNobody));
    // After an acknowledgement and a reliable send with its payload: still found.
    ENetProtocolAcknowledge ack{};
    ack.header.command = ENET_PROTOCOL_COMMAND_ACKNOWLEDGE;
    ENetProtocolSendReliable send{};
    send.header.command = ENET_PROTOCOL_COMMAND_SEND_RELIABLE;
    send.dataLength = ENET_HOST_TO_NET_16(3);
    const auto append = [](std::vector<std::uint8_t>& to, const auto& command) {
        const auto* b = reinterpret_cast<const std::uint8_t*>(&command);
        to.insert(to.end(), b, b + sizeof command);
    };
    d = header();
    append(d, ack);
    append(d, send);
    d.insert(d.end(), {1, 2, 3});
    d.insert(d.end(), verify_command.begin(), verify_command.end());
    EXPECT_TRUE(c.stale(d, kNobody));
    // A payload said to run past the datagram's end ends the walk (ENet stops there too).
    d = header();
    send.dataLength = ENET_HOST_TO_NET_16(static_cast<std::uint16_t>(verify_command.size() + 1));
    append(d, send);
    d.insert(d.end(), verify_command.begin(), verify_command.end());
    EXPECT_FALSE(c.stale(d, kNobody));
    // An unknown command ends it too.
    d = header();
    d.insert(d.end(), {15, 0, 0, 0});
    d.insert(d.end(), verify_command.begin(), verify_command.end());
    EXPECT_FALSE(c.stale(d, kNobody));
    // Only the first verify counts (a second finds the slot no longer connecting).
    d = verify_for(c.connect, c.peer->connectID);
    d.insert(d.end(), verify_command.begin(), verify_command.end());
    EXPECT_FALSE(c.stale(d, kNobody));
}

// Real UDP: a fake server answers an EnetTransport's connect with the answer to an older connect
// from the same slot, then with the right one. Unfixed, the first ends the connect (Disconnected)
// and the second finds the slot gone.
TEST(StaleVerify, AnEnetTransportConnectSurvivesAStaleVerify) {
    ensure_enet_initialized();
    ENetSocket fake = enet_socket_create(ENET_SOCKET_TYPE_DATAGRAM);
    ASSERT_NE(fake, ENET_SOCKET_NULL);
    ENetAddress bind_to = loopback(0);
    ASSERT_EQ(enet_socket_bind(fake, &bind_to), 0);
    ENetAddress fake_address{};
    ASSERT_EQ(enet_socket_get_address(fake, &fake_address), 0);
    enet_socket_set_option(fake, ENET_SOCKOPT_NONBLOCK, 1);

    EnetTransport client(EnetConfig{.local_id = 1});
    ASSERT_TRUE(client.connect(0, "127.0.0.1", fake_address.port));
    bool answered = false, connected = false, disconnected = false;
    std::vector<std::uint8_t> buffer(ENET_PROTOCOL_MAXIMUM_MTU);
    const bool done = run_until(
        5.0,
        [&] {
            client.poll(micros_now());
            TransportEvent e;
            while (client.next_event(e)) {
                if (e.type == TransportEvent::Type::Connected) connected = true;
                if (e.type == TransportEvent::Type::Disconnected) disconnected = true;
            }
            if (answered) return;
            ENetAddress from{};
            ENetBuffer b{buffer.data(), buffer.size()};
            const int n = enet_socket_receive(fake, &from, &b, 1);
            if (n <= 0) return;
            EnetDatagram d;
            ASSERT_TRUE(read_enet_datagram({buffer.data(), static_cast<std::size_t>(n)}, false, d));
            const std::uint8_t* c = find_enet_command(d.commands, ENET_PROTOCOL_COMMAND_CONNECT);
            ASSERT_NE(c, nullptr);
            ENetProtocolConnect connect;
            std::memcpy(&connect, c, sizeof connect);
            for (const enet_uint32 id : {connect.connectID ^ 1u, connect.connectID}) {
                std::vector<std::uint8_t> v = verify_for(connect, id);
                ENetBuffer out{v.data(), v.size()};
                ASSERT_EQ(enet_socket_send(fake, &from, &out, 1), static_cast<int>(v.size()));
            }
            answered = true;
        },
        [&] { return connected || disconnected; });
    enet_socket_destroy(fake);
    ASSERT_TRUE(answered);
    EXPECT_TRUE(done);
    EXPECT_TRUE(connected);
    EXPECT_FALSE(disconnected);
    EXPECT_EQ(client.enet_counters().dropped_stale_verify, 1u);
}

// One host, one place per address: a client slot that gives its connect up and connects again
// (before the server answered the first) is admitted, the first handshake reset. Unfixed, the
// first handshake holds the address's place and the second connect is refused for 30 s.
TEST(ServerHandshakes, AConnectFromAHandshakesClientSlotEndsThatHandshake) {
    EnetServer server(one_place_per_address());
    ASSERT_EQ(server.host_count(), 1u);
    ENetHost* client = enet_host_create(nullptr, 1, 2, 0, 0);
    ASSERT_NE(client, nullptr);
    const ENetAddress to = loopback(server.port());
    ENetPeer* first = enet_host_connect(client, &to, 2, 0);
    ASSERT_NE(first, nullptr);
    enet_host_flush(client);
    enet_peer_reset(first);  // given up: the slot connects again
    ENetPeer* second = enet_host_connect(client, &to, 2, 0);
    ASSERT_EQ(second, first);  // the same slot
    enet_host_flush(client);
    EXPECT_TRUE(both_connected(server, client, 3.0));
    EXPECT_EQ(server.counters().handshakes_abandoned, 1u);
    EXPECT_EQ(server.connection_count(), 1u);
}

// One place per address, held by a handshake whose client vanished (its host destroyed after its
// connect left): the place is free again after kHandshakeTimeoutMs, so another client from the
// address gets in on a later resend of its connect. Unfixed, ENet's 30 s hold it past the bound.
TEST(ServerHandshakes, AHandshakeNobodyAcknowledgesGivesUpItsPlace) {
    EnetServer server(one_place_per_address());
    const ENetAddress to = loopback(server.port());
    ENetHost* gone = enet_host_create(nullptr, 1, 2, 0, 0);
    ASSERT_NE(gone, nullptr);
    ASSERT_NE(enet_host_connect(gone, &to, 2, 0), nullptr);
    enet_host_flush(gone);
    enet_host_destroy(gone);
    ENetHost* client = enet_host_create(nullptr, 1, 2, 0, 0);
    ASSERT_NE(client, nullptr);
    ASSERT_NE(enet_host_connect(client, &to, 2, 0), nullptr);
    // The client's connect is resent after 0.5, 1.5, 3.5 and 7.5 s; the handshake gives up at
    // about kHandshakeTimeoutMs, so the 7.5 s resend is admitted. The bound leaves a margin but
    // stays well under ENet's 30 s.
    static_assert(kHandshakeTimeoutMs < 7'000);
    EXPECT_TRUE(both_connected(server, client, 12.0));
    EXPECT_EQ(server.connection_count(), 1u);
}

// The slot ENet takes for a connect has the handshake timeout (ENet's reset gave it 30 s), read
// on a plain host whose intercept applies the rule, as EnetServer's does.
TEST(ServerHandshakes, TheSlotAConnectTakesHasTheHandshakeTimeout) {
    ensure_enet_initialized();
    ENetAddress any = loopback(0);
    ENetHost* server = enet_host_create(&any, 4, 2, 0, 0);
    ASSERT_NE(server, nullptr);
    server->intercept = [](ENetHost* host, ENetEvent*) -> int {
        prepare_for_connect(host);
        return 0;
    };
    ENetAddress bound{};
    ASSERT_EQ(enet_socket_get_address(server->socket, &bound), 0);
    ENetHost* client = enet_host_create(nullptr, 1, 2, 0, 0);
    ASSERT_NE(client, nullptr);
    const ENetAddress to = loopback(bound.port);
    ASSERT_NE(enet_host_connect(client, &to, 2, 0), nullptr);
    enet_host_flush(client);
    ENetPeer* taken = nullptr;
    run_until(
        2.0,
        [&] {
            ENetEvent e;
            enet_host_service(server, &e, 1);
        },
        [&] {
            for (std::size_t i = 0; i < server->peerCount && taken == nullptr; ++i)
                if (server->peers[i].state == ENET_PEER_STATE_ACKNOWLEDGING_CONNECT) taken = &server->peers[i];
            return taken != nullptr;
        });
    ASSERT_NE(taken, nullptr);
    EXPECT_EQ(taken->timeoutMaximum, kHandshakeTimeoutMs);
    EXPECT_EQ(taken->timeoutMinimum, kHandshakeTimeoutMs);
    enet_host_destroy(client);
    enet_host_destroy(server);
}
