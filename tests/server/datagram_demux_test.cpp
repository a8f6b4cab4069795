// DatagramDemux (server/datagram_demux.h): which ENet host behind the shared socket a datagram
// reaches. A connect goes to the least-loaded host and its repeats follow it; a datagram naming
// a server peer reaches that peer's host with the host's own index in its header; nothing a
// datagram from another address says moves a connection; per-IP and capacity limits drop
// connects; handshakes that never finish free their place; the server's VERIFY_CONNECT is
// rewritten to the id the clients use. Datagrams are built here byte by byte from ENet's
// protocol structs (enet/protocol.h), as ENet 1.3 puts them on the wire.
#include "server/datagram_demux.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace lockroll::server {
namespace {

constexpr std::uint32_t kIpA = 0x0100007F;  // 127.0.0.1 in network byte order
constexpr std::uint32_t kIpB = 0x0200007F;  // 127.0.0.2

std::uint8_t cmd(int command, bool acknowledge) {
    return static_cast<std::uint8_t>(command | (acknowledge ? static_cast<int>(ENET_PROTOCOL_COMMAND_FLAG_ACKNOWLEDGE) : 0));
}

std::vector<std::uint8_t> header(std::uint16_t peer_field, bool sent_time) {
    if (sent_time) peer_field = static_cast<std::uint16_t>(peer_field | ENET_PROTOCOL_HEADER_FLAG_SENT_TIME);
    std::vector<std::uint8_t> d{static_cast<std::uint8_t>(peer_field >> 8), static_cast<std::uint8_t>(peer_field)};
    if (sent_time) d.insert(d.end(), {0x12, 0x34});
    return d;
}

// A client's connect: no peer id yet, a CONNECT command carrying connect_id, from the client's
// peer slot client_peer.
std::vector<std::uint8_t> connect_datagram(std::uint32_t connect_id, std::uint16_t client_peer = 0) {
    auto d = header(ENET_PROTOCOL_MAXIMUM_PEER_ID, true);
    ENetProtocolConnect c{};
    c.header.command = cmd(ENET_PROTOCOL_COMMAND_CONNECT, true);
    c.header.channelID = 0xFF;
    c.connectID = connect_id;
    c.outgoingPeerID = ENET_HOST_TO_NET_16(client_peer);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&c);
    d.insert(d.end(), p, p + sizeof c);
    return d;
}

// A connected client's datagram to server peer `peer` (session bits 2): a ping.
std::vector<std::uint8_t> peer_datagram(std::uint16_t peer) {
    auto d = header(static_cast<std::uint16_t>(peer | (2u << ENET_PROTOCOL_HEADER_SESSION_SHIFT)), true);
    ENetProtocolPing c{};
    c.header.command = cmd(ENET_PROTOCOL_COMMAND_PING, true);
    c.header.channelID = 0xFF;
    const auto* p = reinterpret_cast<const std::uint8_t*>(&c);
    d.insert(d.end(), p, p + sizeof c);
    return d;
}

// route() of a datagram the test does not look at afterwards.
int route(DatagramDemux& d, std::uint32_t ip, std::uint16_t port, std::vector<std::uint8_t> datagram, std::uint64_t now) {
    return d.route(ip, port, datagram, now);
}

std::uint16_t peer_field(const std::vector<std::uint8_t>& d) { return static_cast<std::uint16_t>((d[0] << 8) | d[1]); }

DatagramDemuxConfig config(std::size_t hosts, std::size_t capacity, std::size_t per_ip = 64) {
    DatagramDemuxConfig c;
    c.hosts = hosts;
    c.capacity_per_host = capacity;
    c.max_per_ip = per_ip;
    c.pending_us = 1'000'000;
    return c;
}

TEST(DatagramDemux, ConnectsGoToTheLeastLoadedHostAndTheirRepeatsFollow) {
    DatagramDemux d(config(3, 2));
    auto a = connect_datagram(0xA);
    auto b = connect_datagram(0xB);
    auto c = connect_datagram(0xC);
    EXPECT_EQ(d.route(kIpA, 5000, a, 0), 0);
    EXPECT_EQ(d.route(kIpA, 5001, b, 0), 1);  // host 0 holds a's handshake
    // a's connect again (ENet resends it until answered): the host that has its handshake, not
    // the least-loaded (host 2).
    EXPECT_EQ(d.route(kIpA, 5000, a, 10), 0);
    EXPECT_EQ(d.route(kIpA, 5002, c, 20), 2);
    EXPECT_EQ(d.load(0), 1u);
    EXPECT_EQ(d.load(1), 1u);
    EXPECT_EQ(d.load(2), 1u);
    EXPECT_EQ(d.counters().connects, 3u);
    EXPECT_EQ(d.counters().connect_repeats, 1u);
    // The handshakes become connections: the load stays, the handshakes are done.
    d.connected(0, kIpA, 5000, 0xA);
    d.connected(1, kIpA, 5001, 0xB);
    EXPECT_EQ(d.load(0), 1u);
    EXPECT_EQ(d.handshakes(), 1u);
    // The next connect: host 0 (loads 1, 1, 1: the lowest index).
    EXPECT_EQ(route(d, kIpB, 7000, connect_datagram(0xD), 30), 0);
    d.disconnected(1, kIpA, 5001, 0xB);
    EXPECT_EQ(d.load(1), 0u);
    EXPECT_EQ(route(d, kIpB, 7001, connect_datagram(0xE), 40), 1);
}

TEST(DatagramDemux, APeersDatagramReachesItsHostWithTheHostsOwnIndex) {
    DatagramDemux d(config(4, 3));  // server peer ids 0..11: host = id / 3
    auto p7 = peer_datagram(7);
    EXPECT_EQ(d.route(kIpA, 5000, p7, 0), 2);
    // The header names the host's peer 1 now; the session and the flags are the client's.
    EXPECT_EQ(peer_field(p7) & ENET_PROTOCOL_MAXIMUM_PEER_ID, 1);
    EXPECT_EQ((peer_field(p7) & ENET_PROTOCOL_HEADER_SESSION_MASK) >> ENET_PROTOCOL_HEADER_SESSION_SHIFT, 2);
    EXPECT_NE(peer_field(p7) & ENET_PROTOCOL_HEADER_FLAG_SENT_TIME, 0);
    auto p0 = peer_datagram(0);
    EXPECT_EQ(d.route(kIpA, 5000, p0, 0), 0);
    EXPECT_EQ(peer_field(p0) & ENET_PROTOCOL_MAXIMUM_PEER_ID, 0);
    // An id no host has.
    auto p12 = peer_datagram(12);
    EXPECT_EQ(d.route(kIpA, 5000, p12, 0), DatagramDemux::kDrop);
    EXPECT_EQ(d.counters().peers, 2u);
}

TEST(DatagramDemux, ASpoofedDatagramCannotMoveAConnection) {
    DatagramDemux d(config(4, 1));
    auto a = connect_datagram(0xA);
    ASSERT_EQ(d.route(kIpA, 5000, a, 0), 0);
    d.connected(0, kIpA, 5000, 0xA);  // server peer 0 at 127.0.0.1:5000
    // Someone else (another address) names peer 0: it reaches peer 0's host, whose ENet drops it
    // for its address, as one host always did. Routing never looks at the sender for a peer.
    auto spoof = peer_datagram(0);
    EXPECT_EQ(d.route(kIpB, 9999, spoof, 1), 0);
    // A connect from another address that copies a's connect id is a new handshake, on the
    // least-loaded host; the connection at host 0 is untouched (its load is still 1).
    EXPECT_EQ(route(d, kIpB, 9999, connect_datagram(0xA), 2), 1);
    EXPECT_EQ(d.load(0), 1u);
    // A repeat of a's connect, late (a's connection is up): host 0, which drops it.
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(0xA), 3), 0);
    // ENet's disconnect of a peer of another host releases nothing of host 0's.
    d.disconnected(2, kIpA, 5000, 0xA);
    EXPECT_EQ(d.load(0), 1u);
    // a's own datagrams still reach host 0.
    auto own = peer_datagram(0);
    EXPECT_EQ(d.route(kIpA, 5000, own, 3), 0);
}

TEST(DatagramDemux, LimitsDropConnectsAndAnythingElseFromNobody) {
    DatagramDemux d(config(2, 1, /*per_ip*/ 1));
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(1), 0), 0);
    EXPECT_EQ(route(d, kIpA, 5001, connect_datagram(2), 0), DatagramDemux::kDrop);  // 127.0.0.1 holds 1
    EXPECT_EQ(d.counters().dropped_limit, 1u);
    EXPECT_EQ(route(d, kIpB, 5000, connect_datagram(3), 0), 1);
    EXPECT_EQ(route(d, kIpB + 0x01000000, 5000, connect_datagram(4), 0), DatagramDemux::kDrop);  // both hosts full
    EXPECT_EQ(d.counters().dropped_full, 1u);
    // No peer id and not a connect (a ping from nobody), and a runt.
    auto ping = peer_datagram(ENET_PROTOCOL_MAXIMUM_PEER_ID);
    EXPECT_EQ(d.route(kIpA, 6000, ping, 0), DatagramDemux::kDrop);
    std::vector<std::uint8_t> runt{0xFF};
    EXPECT_EQ(route(d, kIpA, 6000, runt, 0), DatagramDemux::kDrop);
    EXPECT_EQ(d.counters().dropped_unknown, 2u);
}

TEST(DatagramDemux, AHandshakeThatNeverFinishesFreesItsPlace) {
    DatagramDemux d(config(1, 1, 1));
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(1), 0), 0);
    EXPECT_EQ(route(d, kIpB, 5000, connect_datagram(2), 500'000), DatagramDemux::kDrop);  // full
    // pending_us (1 s) later the handshake's place is free, and so is 127.0.0.1's.
    EXPECT_EQ(route(d, kIpB, 5000, connect_datagram(2), 1'000'000), 0);
    EXPECT_EQ(d.load(0), 1u);
    EXPECT_EQ(d.handshakes(), 1u);
}

// Issue 20: a client that connects again from the same port and client slot before its last
// connect finished (a refused client cycling, or one whose ENet gave its connect up) held a
// handshake per connect for pending_us, until its IP's max_per_ip was full and every connect
// from the IP, an honest neighbour's too, was dropped for the rest of those 30 s.
TEST(DatagramDemux, AConnectFromAHandshakesClientSlotAbandonsIt) {
    DatagramDemux d(config(3, 4, /*per_ip*/ 3));
    ASSERT_EQ(route(d, kIpA, 5000, connect_datagram(1, 0), 0), 0);
    // The same slot again, a new connect id: the old handshake is given up and reported (before
    // the new one is placed: host 0 is the least loaded again).
    ASSERT_EQ(route(d, kIpA, 5000, connect_datagram(2, 0), 10), 0);
    AbandonedHandshake a;
    ASSERT_TRUE(d.next_abandoned(a));
    EXPECT_EQ(a.host, 0u);
    EXPECT_EQ(a.ip, kIpA);
    EXPECT_EQ(a.port, 5000);
    EXPECT_EQ(a.connect_id, 1u);
    EXPECT_FALSE(d.next_abandoned(a));
    EXPECT_EQ(d.load(0), 1u);
    EXPECT_EQ(d.handshakes(), 1u);
    // A repeat of the live connect abandons nothing; another slot or port is another client.
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(2, 0), 20), 0);
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(3, 1), 30), 1);
    EXPECT_FALSE(d.next_abandoned(a));
    EXPECT_EQ(d.handshakes(), 2u);
    // A cycler from one slot holds one handshake however fast it cycles: the IP keeps room.
    for (std::uint32_t id = 100; id < 200; ++id) ASSERT_NE(route(d, kIpA, 6000, connect_datagram(id, 0), 40), DatagramDemux::kDrop);
    EXPECT_EQ(d.counters().abandoned, 100u);
    EXPECT_EQ(d.counters().dropped_limit, 0u);
    EXPECT_EQ(d.handshakes(), 3u);
    // The per-IP limit still holds against connects from other ports and slots.
    EXPECT_EQ(route(d, kIpA, 7000, connect_datagram(300, 0), 50), DatagramDemux::kDrop);
    // A handshake that became a connection is not abandoned by a later connect from its slot
    // (ENet's events end a connection); that connect is a new handshake.
    d.connected(0, kIpA, 5000, 2);
    while (d.next_abandoned(a)) {}
    const std::size_t load = d.load(0) + d.load(1) + d.load(2);
    EXPECT_EQ(route(d, kIpA, 5000, connect_datagram(4, 0), 60), DatagramDemux::kDrop);  // 127.0.0.1 holds 3
    EXPECT_FALSE(d.next_abandoned(a));
    EXPECT_EQ(d.load(0) + d.load(1) + d.load(2), load);
    // An expired or connected handshake leaves nothing behind for its slot.
    EXPECT_EQ(route(d, kIpB, 5000, connect_datagram(7, 0), 70), 0);
    EXPECT_NE(route(d, kIpB, 5000, connect_datagram(8, 0), 2'000'000), DatagramDemux::kDrop);  // 7 expired first
    EXPECT_FALSE(d.next_abandoned(a));
}

TEST(DatagramDemux, TheLastHostHoldsTheRestAndPeerIdsStayBelowEnetsLimit) {
    DatagramDemuxConfig c = config(3, 4);
    c.connections = 10;  // hosts of 4, 4 and 2
    DatagramDemux d(c);
    EXPECT_EQ(d.capacity(2), 2u);
    c.connections = 13;  // more than 3 hosts of 4 hold
    EXPECT_THROW(DatagramDemux{c}, std::invalid_argument);
    c.hosts = 4095;
    c.capacity_per_host = 1;
    c.connections = 0;  // 4,095 ids: 0xFFF would be "no peer"
    EXPECT_THROW(DatagramDemux{c}, std::invalid_argument);
}

TEST(DatagramDemux, TheServersVerifyConnectNamesTheServersPeerId) {
    DatagramDemux d(config(4, 3));
    // Host 2's answer to a connect: an acknowledgement, then VERIFY_CONNECT naming its peer 1.
    auto out = header(5, true);  // to the client's peer 5
    ENetProtocolAcknowledge ack{};
    ack.header.command = cmd(ENET_PROTOCOL_COMMAND_ACKNOWLEDGE, false);
    ENetProtocolVerifyConnect v{};
    v.header.command = cmd(ENET_PROTOCOL_COMMAND_VERIFY_CONNECT, true);
    v.outgoingPeerID = ENET_HOST_TO_NET_16(1);
    const auto* pa = reinterpret_cast<const std::uint8_t*>(&ack);
    const auto* pv = reinterpret_cast<const std::uint8_t*>(&v);
    out.insert(out.end(), pa, pa + sizeof ack);
    const std::size_t at = out.size() + offsetof(ENetProtocolVerifyConnect, outgoingPeerID);
    out.insert(out.end(), pv, pv + sizeof v);
    d.outgoing(2, out);
    EXPECT_EQ((out[at] << 8) | out[at + 1], 2 * 3 + 1);
    // Host 0's indexes are the ids already.
    auto zero = out;
    zero[at] = 0;
    zero[at + 1] = 1;
    d.outgoing(0, zero);
    EXPECT_EQ((zero[at] << 8) | zero[at + 1], 1);
    // A payload that looks like a VERIFY_CONNECT inside a send command is data: untouched.
    auto data = header(5, true);
    ENetProtocolSendReliable s{};
    s.header.command = cmd(ENET_PROTOCOL_COMMAND_SEND_RELIABLE, true);
    s.dataLength = ENET_HOST_TO_NET_16(sizeof v);
    const auto* ps = reinterpret_cast<const std::uint8_t*>(&s);
    data.insert(data.end(), ps, ps + sizeof s);
    data.insert(data.end(), pv, pv + sizeof v);
    const auto before = data;
    d.outgoing(2, data);
    EXPECT_EQ(data, before);
    // A datagram without a sent time has no reliable command: untouched.
    auto plain = header(5, false);
    plain.insert(plain.end(), pv, pv + sizeof v);
    const auto plain_before = plain;
    d.outgoing(2, plain);
    EXPECT_EQ(plain, plain_before);
}

}  // namespace
}  // namespace lockroll::server
