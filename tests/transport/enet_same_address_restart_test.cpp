// A killed process restarted at its old address (the same port, as `lockroll peer` and the
// live harness's proxies give it) must keep the connection it dials, issue 21.
//
// The killed process never said goodbye, so its peer still holds a connection to that address.
// ENet tells connections apart by the receiver's peer slot, the address and a 2-bit session id;
// a fresh host's first connection gets the same slot and, from a fresh slot on the other side,
// the same session id as the killed process's first connection had. So anything the peer still
// sends on the dead connection is taken by the successor's new connection as its own. Before
// the fix, the peer closed the silent connection it replaced with a disconnect ("replaced"):
// the successor's new connection took it and closed, the peer then held a connection nobody
// answered and refused the successor's redials as "id held by a live connection" for seconds.
// Over real processes (lockroll live, slot 0 killed at 200 and rejoined at 400, 5 % loss) the
// rejoiner lost its connections that way again and again and did not complete.
#include "transport/enet_transport.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace lockroll::transport {
namespace {

// Services the transports (and an optional raw ENet host) until `done` or ~4 s of real time.
bool pump(const std::vector<EnetTransport*>& hosts, const std::function<bool()>& done, Micros& now,
          ENetHost* raw = nullptr) {
    for (int i = 0; i < 4000; ++i) {
        for (EnetTransport* h : hosts) h->poll(now);
        if (raw != nullptr)
            for (ENetEvent e; enet_host_service(raw, &e, 0) > 0;)
                if (e.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(e.packet);
        if (done()) return true;
        now += 1'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return done();
}

std::vector<TransportEvent> events_of(EnetTransport& t) {
    std::vector<TransportEvent> out;
    for (TransportEvent e; t.next_event(e);) out.push_back(e);
    return out;
}

TEST(EnetSameAddressRestart, ARestartedProcessAtItsOldAddressKeepsTheConnectionItDials) {
    EnetTransport a({.local_id = 0});
    Micros now = 0;
    ENetAddress a_addr{};
    enet_address_set_host(&a_addr, "127.0.0.1");
    a_addr.port = a.port();

    // The old process of id 1 (plain ENet, so that it can die without a word: enet_host_destroy
    // sends nothing) dials a, as a lower survivor's peer would be dialed by a higher one.
    ENetAddress any{};
    enet_address_set_host(&any, "127.0.0.1");
    any.port = 0;
    ENetHost* old_host = enet_host_create(&any, 64, 2, 0, 0);
    ASSERT_NE(old_host, nullptr);
    ENetAddress bound{};
    ASSERT_EQ(enet_socket_get_address(old_host->socket, &bound), 0);
    const std::uint16_t old_port = bound.port;
    ENetPeer* old_peer = enet_host_connect(old_host, &a_addr, 2, 1);
    ASSERT_NE(old_peer, nullptr);
    ASSERT_TRUE(pump({&a}, [&] { return a.is_connected(1) && old_peer->state == ENET_PEER_STATE_CONNECTED; }, now, old_host));
    events_of(a);
    enet_host_destroy(old_host);  // SIGKILL: the socket closes, no disconnect is sent

    // A second of a's time without a word from it: its connection is silent.
    for (int i = 0; i < 1200; ++i) {
        a.poll(now);
        now += 1'000;
    }

    // The successor binds the old port and dials a.
    EnetTransport restarted({.local_id = 1, .port = old_port});
    ASSERT_TRUE(restarted.connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return restarted.is_connected(0) && a.is_connected(1); }, now));
    // Whatever a still sends to the old connection, also when it gives it up for its silence
    // (dead_after_us, 5 s of a's time since it was last heard), must not reach the successor's
    // connection as its own. A second of real time (ENet pings by its own clock, every 0.5 s);
    // a's clock runs 5 times as fast meanwhile, the successor's at the real rate.
    Micros now_r = now;
    const auto both = [&](const std::function<bool()>& done) {
        for (int i = 0; i < 4000; ++i) {
            a.poll(now += 5'000);
            restarted.poll(now_r += 1'000);
            if (done()) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        return done();
    };
    int ticks = 0;
    both([&] { return ++ticks >= 1000; });
    for (const auto& e : events_of(restarted))
        EXPECT_NE(e.type, TransportEvent::Type::Disconnected) << "the successor's connection was closed: " << e.reason;
    ASSERT_TRUE(restarted.is_connected(0));
    ASSERT_TRUE(a.is_connected(1));

    // And it carries datagrams both ways.
    const std::vector<std::uint8_t> ping{1, 2, 3, 4}, pong{5, 6, 7};
    ASSERT_TRUE(a.send(1, ping, now));
    Datagram d;
    ASSERT_TRUE(both([&] { return restarted.receive(d, now_r); }));
    EXPECT_EQ(d.bytes, ping);
    ASSERT_TRUE(restarted.send(0, pong, now_r));
    ASSERT_TRUE(both([&] { return a.receive(d, now); }));
    EXPECT_EQ(d.from, 1u);
    EXPECT_EQ(d.bytes, pong);
}

}  // namespace
}  // namespace lockroll::transport
