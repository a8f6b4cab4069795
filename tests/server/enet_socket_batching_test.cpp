// The interposer of ENet's socket calls (server/enet_socket_batching.cpp, linked into this test
// as into lockroll-server): its self-check finds it live; an ENet server host whose socket is
// installed in Batch mode exchanges every datagram with plain ENet clients (their sockets not
// installed, so ENet's own calls) in far fewer syscalls than datagrams; Count mode counts one
// syscall per datagram. One process, 127.0.0.1, every loop bounded.
#include "server/enet_socket_batching.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "transport/enet_server.h"

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

// Several ENet hosts behind one socket (fanout(), transport::EnetServer with connections_per_host):
// clients, one of them holding two connections from one socket, each reach their own host and
// get back exactly their own datagrams; a connection that leaves frees its host for the next
// connect; the ENet walks a poll makes are those of the hosts with traffic.
TEST(EnetSocketBatching, SeveralHostsShareTheSocketAndEachConnectionKeepsItsOwn) {
    ASSERT_EQ(enet_initialize(), 0);
    {
        transport::EnetServerConfig ec;
        ec.max_connections = 6;
        ec.max_connections_per_address = 64;
        ec.connections_per_host = 1;
        ec.fanout = &fanout();
        transport::EnetServer server(ec);
        ASSERT_EQ(server.fanout_refused(), "");
        ASSERT_EQ(server.host_count(), 6u);
        ENetAddress a{};
        enet_address_set_host(&a, "127.0.0.1");
        a.port = server.port();
        // Clients 0..2 one connection each; client 3 two from one socket (one address).
        std::vector<ENetHost*> clients;
        std::vector<ENetPeer*> peers;
        for (int i = 0; i < 4; ++i) clients.push_back(enet_host_create(nullptr, 2, 2, 0, 0));
        for (int i = 0; i < 4; ++i) peers.push_back(enet_host_connect(clients[static_cast<std::size_t>(i)], &a, 2, 0));
        peers.push_back(enet_host_connect(clients[3], &a, 2, 0));
        for (std::size_t i = 0; i < peers.size(); ++i) peers[i]->data = reinterpret_cast<void*>(i + 1);
        std::uint64_t now = 1'000'000;
        std::map<std::size_t, int> connected;      // client peer index -> events
        std::map<std::size_t, std::set<std::uint8_t>> got;  // client peer index -> tags it received
        std::uint64_t bad = 0;
        const auto clients_service = [&] {
            ENetEvent e;
            for (auto* c : clients)
                while (enet_host_service(c, &e, 0) > 0) {
                    const auto i = reinterpret_cast<std::size_t>(e.peer->data) - 1;
                    if (e.type == ENET_EVENT_TYPE_CONNECT) ++connected[i];
                    if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                        // The server echoes each datagram to the connection it came from.
                        if (e.packet->dataLength != 2 || e.packet->data[0] != i) ++bad;
                        else got[i].insert(e.packet->data[1]);
                        enet_packet_destroy(e.packet);
                    }
                }
        };
        std::vector<std::uint32_t> ids;
        const auto server_pass = [&] {
            now += 1000;
            server.poll(now, 0);
            enet_socket_batching::flush();  // what the hosts sent waits in the batch until then
            for (transport::ServerConnectionEvent ev; server.next_event(ev);)
                if (ev.type == transport::ServerConnectionEvent::Type::Connected) ids.push_back(ev.connection);
            for (transport::ServerDatagram d; server.receive(d);) server.send(d.connection, d.bytes, false);
            server.flush();
            enet_socket_batching::flush();
        };
        for (int i = 0; i < 2000 && server.connection_count() < peers.size(); ++i) {
            for (auto* c : clients) enet_host_flush(c);
            server_pass();
            clients_service();
        }
        ASSERT_EQ(server.connection_count(), peers.size());
        ASSERT_EQ(connected.size(), peers.size());
        for (int round = 0; round < 20; ++round) {
            for (std::size_t i = 0; i < peers.size(); ++i) {
                const std::uint8_t msg[2] = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(round)};
                enet_peer_send(peers[i], 0, enet_packet_create(msg, sizeof msg, ENET_PACKET_FLAG_UNSEQUENCED));
            }
            for (auto* c : clients) enet_host_flush(c);
            server_pass();
            clients_service();
            // Echoed in the same pass: the flush reached each connection's own host.
            for (std::size_t i = 0; i < peers.size(); ++i)
                EXPECT_EQ(got[i].count(static_cast<std::uint8_t>(round)), 1u) << "connection " << i << " round " << round;
        }
        for (int i = 0; i < 20; ++i) {
            server_pass();
            clients_service();
        }
        EXPECT_EQ(bad, 0u);
        for (std::size_t i = 0; i < peers.size(); ++i) EXPECT_EQ(got[i].size(), 20u) << "connection " << i;
        // Traffic from 5 connections: far fewer services than 6 hosts x every pass, each walking 1 slot.
        EXPECT_GT(server.counters().host_services, 0u);
        // The echoes were written straight to the shared socket under each host's id (direct
        // unreliable sends), and each still reached its own connection (above); the clients'
        // unsequenced datagrams were taken from the fanout without their host's ENet.
        EXPECT_GE(server.counters().datagrams_direct, 20u * peers.size());
        EXPECT_GE(server.counters().datagrams_in_direct, 20u * peers.size());
        // One leaves: its host takes the next connect (the only free ones: 1 of 6, plus the
        // one never used).
        enet_peer_disconnect(peers[0], 0);
        for (int i = 0; i < 200 && server.connection_count() == peers.size(); ++i) {
            for (auto* c : clients) enet_host_flush(c);
            server_pass();
            clients_service();
        }
        EXPECT_EQ(server.connection_count(), peers.size() - 1);
        ENetHost* late = enet_host_create(nullptr, 2, 2, 0, 0);
        ENetPeer* lp = enet_host_connect(late, &a, 2, 0);
        ENetHost* later = enet_host_create(nullptr, 2, 2, 0, 0);
        ENetPeer* lp2 = enet_host_connect(later, &a, 2, 0);
        bool up = false, up2 = false;
        for (int i = 0; i < 2000 && !(up && up2); ++i) {
            enet_host_flush(late);
            enet_host_flush(later);
            server_pass();
            clients_service();
            ENetEvent e;
            while (enet_host_service(late, &e, 0) > 0) up = up || (e.type == ENET_EVENT_TYPE_CONNECT && e.peer == lp);
            while (enet_host_service(later, &e, 0) > 0) up2 = up2 || (e.type == ENET_EVENT_TYPE_CONNECT && e.peer == lp2);
        }
        EXPECT_TRUE(up);
        EXPECT_TRUE(up2);
        for (int i = 0; i < 20; ++i) {  // the server hears their acknowledgements
            enet_host_flush(late);
            enet_host_flush(later);
            server_pass();
        }
        EXPECT_EQ(server.connection_count(), peers.size() + 1);  // all 6 hosts full
        enet_host_destroy(late);
        enet_host_destroy(later);
        for (auto* c : clients) enet_host_destroy(c);
    }
    enet_deinitialize();
}

// The datagrams EnetServer takes from the fanout itself (one unsequenced packet each) pass ENet's
// own checks: a repeat of a group is dropped, the same bytes from another address go to the
// host's ENet (which drops them: that connection is not theirs), and the connection's ENet
// traffic goes on after them.
TEST(EnetSocketBatching, TakenDatagramsKeepEnetsChecks) {
    ASSERT_EQ(enet_initialize(), 0);
    {
        transport::EnetServerConfig ec;
        ec.max_connections = 4;
        ec.connections_per_host = 2;
        ec.fanout = &fanout();
        transport::EnetServer server(ec);
        ASSERT_EQ(server.host_count(), 2u);
        ENetAddress a{};
        enet_address_set_host(&a, "127.0.0.1");
        a.port = server.port();
        ENetHost* client = enet_host_create(nullptr, 1, 2, 0, 0);
        ENetPeer* peer = enet_host_connect(client, &a, 2, 0);
        std::uint64_t now = 1'000'000;
        std::vector<std::vector<std::uint8_t>> got;
        const auto pass = [&] {
            now += 1000;
            server.poll(now, 0);
            enet_socket_batching::flush();
            for (transport::ServerConnectionEvent ev; server.next_event(ev);) {}
            for (transport::ServerDatagram d; server.receive(d);) got.emplace_back(d.bytes.begin(), d.bytes.end());
            server.flush();
            enet_socket_batching::flush();
            ENetEvent e;
            while (enet_host_service(client, &e, 0) > 0)
                if (e.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(e.packet);
        };
        for (int i = 0; i < 2000 && !(server.connection_count() == 1 && peer->state == ENET_PEER_STATE_CONNECTED); ++i) pass();
        ASSERT_EQ(peer->state, ENET_PEER_STATE_CONNECTED);
        for (int i = 0; i < 20; ++i) pass();  // the handshake's last acknowledgement reaches the server
        // One unsequenced packet as the client's ENet would send it, under its next group.
        const auto datagram = [&](std::uint16_t group, std::uint8_t tag) {
            const std::uint16_t id = static_cast<std::uint16_t>(peer->outgoingPeerID | (peer->outgoingSessionID << ENET_PROTOCOL_HEADER_SESSION_SHIFT));
            return std::vector<std::uint8_t>{static_cast<std::uint8_t>(id >> 8), static_cast<std::uint8_t>(id), 9 | 64, 0, 0, 0,
                                             static_cast<std::uint8_t>(group >> 8), static_cast<std::uint8_t>(group), 0, 2, 'x', tag};
        };
        const auto send_raw = [&](ENetSocket from, const std::vector<std::uint8_t>& bytes) {
            ENetBuffer b;
            b.data = const_cast<std::uint8_t*>(bytes.data());
            b.dataLength = bytes.size();
            ASSERT_EQ(enet_socket_send(from, &a, &b, 1), static_cast<int>(bytes.size()));
        };
        const std::uint16_t group = static_cast<std::uint16_t>(peer->outgoingUnsequencedGroup + 1);
        peer->outgoingUnsequencedGroup = group;  // the client's ENet goes on after it
        const std::uint64_t before = server.counters().datagrams_in_direct;
        send_raw(client->socket, datagram(group, 1));
        send_raw(client->socket, datagram(group, 2));  // the same group again: a repeat
        ENetSocket stranger = enet_socket_create(ENET_SOCKET_TYPE_DATAGRAM);
        ASSERT_NE(stranger, ENET_SOCKET_NULL);
        send_raw(stranger, datagram(static_cast<std::uint16_t>(group + 1), 3));  // right id and session, wrong address
        for (int i = 0; i < 20; ++i) pass();
        enet_socket_destroy(stranger);
        ASSERT_EQ(got.size(), 1u);
        EXPECT_EQ(got[0], (std::vector<std::uint8_t>{'x', 1}));
        EXPECT_EQ(server.counters().datagrams_in_direct, before + 1);
        EXPECT_EQ(server.counters().repeats_direct, 1u);
        // The client's own ENet sends still arrive.
        const std::uint8_t bytes[2] = {'y', 4};
        enet_peer_send(peer, 0, enet_packet_create(bytes, sizeof bytes, ENET_PACKET_FLAG_UNSEQUENCED));
        enet_host_flush(client);
        for (int i = 0; i < 200 && got.size() < 2; ++i) pass();
        ASSERT_EQ(got.size(), 2u);
        EXPECT_EQ(got[1], (std::vector<std::uint8_t>{'y', 4}));
        EXPECT_EQ(server.counters().datagrams_in_direct, before + 2);
        EXPECT_EQ(server.connection_count(), 1u);
        enet_host_destroy(client);
    }
    enet_deinitialize();
}

}  // namespace
}  // namespace lockroll::server::enet_socket_batching
