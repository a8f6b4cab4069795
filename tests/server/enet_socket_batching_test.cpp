// The interposer of ENet's socket calls (server/enet_socket_batching.cpp, linked into this test
// as into lockroll-server): its self-check finds it live; an ENet server host whose socket is
// installed in Batch mode exchanges every datagram with plain ENet clients (their sockets not
// installed, so ENet's own calls) in far fewer syscalls than datagrams; Count mode counts one
// syscall per datagram. One process, 127.0.0.1, every loop bounded.
#include "server/enet_socket_batching.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace lockroll::server::enet_socket_batching {
namespace {

struct Pair {
    ENetHost* server = nullptr;
    std::vector<ENetHost*> clients;
    std::vector<ENetPeer*> to_server;
    std::uint64_t server_got = 0, clients_got = 0;
    std::vector<ENetPeer*> server_peers;

    explicit Pair(int n) {
        ENetAddress a{};
        enet_address_set_host(&a, "127.0.0.1");
        server = enet_host_create(&a, static_cast<std::size_t>(n), 2, 0, 0);
        enet_socket_get_address(server->socket, &a);
        for (int i = 0; i < n; ++i) {
            clients.push_back(enet_host_create(nullptr, 1, 2, 0, 0));
            to_server.push_back(enet_host_connect(clients.back(), &a, 2, 0));
        }
    }
    ~Pair() {
        for (auto* c : clients) enet_host_destroy(c);
        enet_host_destroy(server);
    }
    void service_all() {
        ENetEvent e;
        while (enet_host_service(server, &e, 0) > 0) {
            if (e.type == ENET_EVENT_TYPE_CONNECT) server_peers.push_back(e.peer);
            if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                ++server_got;
                enet_packet_destroy(e.packet);
            }
        }
        flush();
        for (auto* c : clients)
            while (enet_host_service(c, &e, 0) > 0)
                if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                    ++clients_got;
                    enet_packet_destroy(e.packet);
                }
    }
    bool connect() {
        for (int i = 0; i < 2000 && server_peers.size() < clients.size(); ++i) service_all();
        return server_peers.size() == clients.size();
    }
    // rounds of: every client sends one, the server answers each with one.
    void exchange(int rounds) {
        const std::uint8_t byte[3] = {1, 2, 3};
        for (int r = 0; r < rounds; ++r) {
            for (auto* p : to_server) enet_peer_send(p, 0, enet_packet_create(byte, sizeof byte, ENET_PACKET_FLAG_UNSEQUENCED));
            for (auto* c : clients) enet_host_flush(c);
            service_all();
            for (auto* p : server_peers) enet_peer_send(p, 0, enet_packet_create(byte, sizeof byte, ENET_PACKET_FLAG_UNSEQUENCED));
            service_all();
        }
        for (int i = 0; i < 20; ++i) service_all();
    }
};

TEST(EnetSocketBatching, BatchesTheInstalledSocketAndLeavesOthersAlone) {
    ASSERT_EQ(enet_initialize(), 0);
    {
        Pair p(16);
        ASSERT_EQ(install(p.server->socket, Mode::Batch), "");  // the self-check found it live
        ASSERT_TRUE(p.connect());
        const Counts before = counts();
        p.exchange(50);
        const Counts after = counts();
        EXPECT_EQ(p.server_got, 16u * 50u);   // nothing lost through the batch
        EXPECT_EQ(p.clients_got, 16u * 50u);
        const std::uint64_t datagrams = (after.datagrams_in - before.datagrams_in) + (after.datagrams_out - before.datagrams_out);
        EXPECT_GE(datagrams, 2u * 16u * 50u);
        // a few syscalls per service, against one per datagram: 16 datagrams in and out per round
        EXPECT_LT(after.syscalls() - before.syscalls(), datagrams / 4);
    }
    enet_deinitialize();
}

TEST(EnetSocketBatching, CountModeCountsOneSyscallPerDatagram) {
    ASSERT_EQ(enet_initialize(), 0);
    {
        Pair p(4);
        ASSERT_EQ(install(p.server->socket, Mode::Count), "");
        ASSERT_TRUE(p.connect());
        const Counts before = counts();
        p.exchange(20);
        const Counts after = counts();
        EXPECT_EQ(p.server_got, 4u * 20u);
        EXPECT_EQ(p.clients_got, 4u * 20u);
        const std::uint64_t datagrams = (after.datagrams_in - before.datagrams_in) + (after.datagrams_out - before.datagrams_out);
        EXPECT_GE(after.syscalls() - before.syscalls(), datagrams);  // every datagram its own, plus the empty reads
    }
    enet_deinitialize();
}

TEST(EnetSocketBatching, RefusesASocketTwice) {
    ASSERT_EQ(enet_initialize(), 0);
    {
        Pair p(1);
        ASSERT_EQ(install(p.server->socket, Mode::Batch), "");
        EXPECT_NE(install(p.server->socket, Mode::Batch), "");
    }
    enet_deinitialize();
}

}  // namespace
}  // namespace lockroll::server::enet_socket_batching
