// EnetBlockPool: size classes, reuse, the free lists' bound, and ENet running on it.
#include "server/enet_block_pool.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

using lockroll::server::EnetBlockPool;

TEST(EnetBlockPool, ReusesAReleasedBlockOfTheSameClass) {
    EnetBlockPool pool;
    void* a = pool.allocate(40);
    ASSERT_NE(a, nullptr);
    std::memset(a, 0xAB, 64);  // the whole class is usable
    pool.release(a);
    EXPECT_EQ(pool.free_blocks(0), 1u);
    void* b = pool.allocate(64);  // same class (<= 64)
    EXPECT_EQ(b, a);
    EXPECT_EQ(pool.free_blocks(0), 0u);
    void* c = pool.allocate(65);  // the next class: not the same block
    EXPECT_NE(c, a);
    pool.release(b);
    pool.release(c);
    EXPECT_EQ(pool.free_blocks(0), 1u);
    EXPECT_EQ(pool.free_blocks(1), 1u);
    EXPECT_EQ(pool.counters().from_malloc, 2u);  // a and c; b came from the list
}

TEST(EnetBlockPool, AlignsTo16AndSendsLargeRequestsToMalloc) {
    EnetBlockPool pool;
    std::vector<void*> blocks;
    for (std::size_t n : {1u, 17u, 100u, 200u, 512u, 513u, 100000u}) {
        void* p = pool.allocate(n);
        ASSERT_NE(p, nullptr) << n;
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % 16, 0u) << n;
        std::memset(p, 0x5A, n);
        blocks.push_back(p);
    }
    EXPECT_EQ(pool.counters().large, 2u);
    for (void* p : blocks) pool.release(p);
    EXPECT_EQ(pool.counters().to_malloc, 2u);  // the large ones are not kept
    EXPECT_EQ(pool.free_blocks(0) + pool.free_blocks(1) + pool.free_blocks(2) + pool.free_blocks(3), 5u);
    pool.release(nullptr);  // as free(nullptr)
}

TEST(EnetBlockPool, KeepsAtMostTheBoundPerClass) {
    EnetBlockPool pool;
    const std::size_t n = EnetBlockPool::kMaxFreePerClass + 10;
    std::vector<void*> blocks(n);
    for (auto& p : blocks) p = pool.allocate(8);
    for (void* p : blocks) pool.release(p);
    EXPECT_EQ(pool.free_blocks(0), EnetBlockPool::kMaxFreePerClass);
    EXPECT_EQ(pool.counters().to_malloc, 10u);
}

// ENet on the pool: a connection and packets both ways over 127.0.0.1, every packet, command
// and host buffer from the installed pool and back.
TEST(EnetBlockPool, CarriesEnetTraffic) {
    ASSERT_EQ(lockroll::server::enet_block_pool::install(), "");
    ASSERT_NE(lockroll::server::enet_block_pool::installed(), nullptr);
    EXPECT_NE(lockroll::server::enet_block_pool::install(), "");  // once only
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = 0;
    ENetHost* server = enet_host_create(&a, 4, 2, 0, 0);
    ASSERT_NE(server, nullptr);
    enet_socket_get_address(server->socket, &a);
    ENetHost* client = enet_host_create(nullptr, 1, 2, 0, 0);
    ASSERT_NE(client, nullptr);
    ENetPeer* to_server = enet_host_connect(client, &a, 2, 0);
    ASSERT_NE(to_server, nullptr);
    int received = 0, sent = 0;
    bool connected = false;
    for (int step = 0; step < 2000 && received < 50; ++step) {
        ENetEvent e;
        while (enet_host_service(client, &e, 0) > 0) {
            if (e.type == ENET_EVENT_TYPE_CONNECT) connected = true;
            if (e.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(e.packet);
        }
        while (enet_host_service(server, &e, 1) > 0)
            if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                EXPECT_EQ(e.packet->dataLength, 3u + static_cast<std::size_t>(received % 300));
                ++received;
                // Echo it back, through ENet's own packet copy.
                enet_peer_send(e.peer, 0, enet_packet_create(e.packet->data, e.packet->dataLength, ENET_PACKET_FLAG_RELIABLE));
                enet_packet_destroy(e.packet);
            }
        if (connected && step % 2 == 0) {
            std::vector<std::uint8_t> bytes(3 + static_cast<std::size_t>(sent++ % 300), static_cast<std::uint8_t>(step));
            enet_peer_send(to_server, 0, enet_packet_create(bytes.data(), bytes.size(), ENET_PACKET_FLAG_RELIABLE));
        }
        enet_host_flush(client);
    }
    EXPECT_GE(received, 50);
    enet_host_destroy(client);
    enet_host_destroy(server);
    const EnetBlockPool& pool = *lockroll::server::enet_block_pool::installed();
    // Over 100 packets each way (and their commands), from fewer blocks: the lists were reused.
    EXPECT_LT(pool.counters().from_malloc, 100u);
    EXPECT_GT(pool.free_blocks(0) + pool.free_blocks(1) + pool.free_blocks(2), 0u);
    EXPECT_GT(pool.counters().large, 0u);  // the hosts' peer arrays
}
