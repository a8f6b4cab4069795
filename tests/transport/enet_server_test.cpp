// EnetServer's unreliable sends written straight to the socket (EnetServerConfig::direct_unsequenced):
// a plain ENet client receives them, byte for byte, as the unsequenced packets ENet would have
// sent, without the server flushing; reliable sends still wait for the flush. 127.0.0.1 only,
// bounded loops.
#include "transport/enet_server.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "transport/enet_library.h"

using namespace lockroll::transport;

namespace {

struct Client {
    ENetHost* host = nullptr;
    ENetPeer* peer = nullptr;
    ~Client() {
        if (host) enet_host_destroy(host);
    }
    // Received packets (channel, bytes), for up to `steps` services of 1 ms.
    std::vector<std::pair<int, std::vector<std::uint8_t>>> received;
    bool connected = false;
    void service(int steps) {
        for (int i = 0; i < steps; ++i) {
            ENetEvent e;
            while (enet_host_service(host, &e, 1) > 0) {
                if (e.type == ENET_EVENT_TYPE_CONNECT) connected = true;
                if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                    received.emplace_back(e.channelID, std::vector<std::uint8_t>(e.packet->data, e.packet->data + e.packet->dataLength));
                    enet_packet_destroy(e.packet);
                }
            }
        }
    }
};

std::vector<std::uint8_t> pattern(std::size_t n, int seed) {
    std::vector<std::uint8_t> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>(i * 7 + static_cast<std::size_t>(seed) * 13);
    return v;
}

// Connects one plain ENet client; returns the server's id for it (0 on failure).
std::uint32_t connect(EnetServer& server, Client& c) {
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = server.port();
    c.host = enet_host_create(nullptr, 1, 2, 0, 0);
    if (!c.host) return 0;
    c.peer = enet_host_connect(c.host, &a, 2, 0);
    for (int step = 0; step < 2000; ++step) {
        c.service(1);
        server.poll(static_cast<Micros>(step) * 1000, 1000);
        ServerConnectionEvent e;
        if (c.connected && server.next_event(e) && e.type == ServerConnectionEvent::Type::Connected) return e.connection;
    }
    return 0;
}

}  // namespace

TEST(EnetServer, UnreliableSendsLeaveAtOnceAsEnetWouldSendThem) {
    ensure_enet_initialized();
    EnetServerConfig config;
    config.max_connections = 8;
    EnetServer server(config);
    Client c;
    const std::uint32_t id = connect(server, c);
    ASSERT_NE(id, 0u);
    // 300 datagrams of sizes up to the largest, then a reliable one; the server is neither
    // polled nor flushed afterwards. The client's ENet drops an unsequenced group it has seen:
    // all 300 arriving shows each went out under the next group, as ENet's own sends do.
    constexpr int kCount = 300;
    std::vector<std::vector<std::uint8_t>> sent;
    for (int i = 0; i < kCount; ++i) {
        sent.push_back(pattern(1 + static_cast<std::size_t>(i) * (kMaxDatagramBytes - 1) / (kCount - 1), i));
        ASSERT_TRUE(server.send(id, sent.back(), false));
    }
    ASSERT_TRUE(server.send(id, pattern(40, 99), true));
    EXPECT_EQ(server.counters().datagrams_direct, static_cast<std::uint64_t>(kCount));
    for (int step = 0; step < 200 && c.received.size() < static_cast<std::size_t>(kCount); ++step) c.service(1);
    ASSERT_EQ(c.received.size(), static_cast<std::size_t>(kCount));  // the reliable one waits for a flush
    std::vector<bool> seen(kCount, false);
    for (const auto& [channel, bytes] : c.received) {
        EXPECT_EQ(channel, 0);
        bool found = false;
        for (int i = 0; i < kCount && !found; ++i)
            if (!seen[static_cast<std::size_t>(i)] && sent[static_cast<std::size_t>(i)] == bytes) found = seen[static_cast<std::size_t>(i)] = true;
        EXPECT_TRUE(found) << "a datagram of " << bytes.size() << " bytes that was not sent";
    }
    // The reliable send (ENet's queue) still leaves with the flush, and the connection is well.
    server.flush();
    for (int step = 0; step < 200 && c.received.size() < static_cast<std::size_t>(kCount) + 1; ++step) {
        c.service(1);
        server.poll(static_cast<Micros>(3000 + step) * 1000, 0);
    }
    ASSERT_EQ(c.received.size(), static_cast<std::size_t>(kCount) + 1);
    EXPECT_EQ(c.received.back().first, 1);
    EXPECT_EQ(c.received.back().second, pattern(40, 99));
    EXPECT_EQ(c.peer->state, ENET_PEER_STATE_CONNECTED);
    EXPECT_GT(server.wire_bytes_sent(), static_cast<std::uint64_t>(kCount) * 10);
}

TEST(EnetServer, WithoutDirectSendsUnreliableOnesWaitForTheFlush) {
    ensure_enet_initialized();
    EnetServerConfig config;
    config.max_connections = 8;
    config.direct_unsequenced = false;
    EnetServer server(config);
    Client c;
    const std::uint32_t id = connect(server, c);
    ASSERT_NE(id, 0u);
    ASSERT_TRUE(server.send(id, pattern(30, 1), false));
    c.service(50);
    EXPECT_TRUE(c.received.empty());
    EXPECT_EQ(server.counters().datagrams_direct, 0u);
    server.flush();
    for (int step = 0; step < 200 && c.received.empty(); ++step) c.service(1);
    ASSERT_EQ(c.received.size(), 1u);
    EXPECT_EQ(c.received[0].second, pattern(30, 1));
}
