#include "transport/enet_transport.h"
#include "transport/header_overhead.h"

#include <enet/enet.h>
#include <gtest/gtest.h>

#include <cstddef>

#include <chrono>
#include <cstdio>
#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace lockroll::transport {
namespace {

// Services every transport until `done` or the bound runs out (at most ~4 s of real time on a
// loaded machine; usually a few milliseconds). Returns whether `done` became true. The clock
// handed to the transports is a plain counter: they must not care.
bool pump(std::vector<EnetTransport*> hosts, const std::function<bool()>& done, Micros& now) {
    for (int i = 0; i < 4000; ++i) {
        for (EnetTransport* h : hosts) h->poll(now);
        if (done()) return true;
        now += 1'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return done();
}

std::vector<std::uint8_t> bytes_of(std::uint8_t tag, std::size_t n) {
    std::vector<std::uint8_t> b(n);
    for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(tag + i);
    return b;
}

// The bandwidth figures' ENet header estimate must match the ENet we build against.
static_assert(offsetof(ENetProtocolHeader, sentTime) == kEnetProtocolHeaderBytes);
static_assert(sizeof(ENetProtocolSendUnsequenced) == kEnetSendUnsequencedBytes);
static_assert(kEnetUdpIpv4HeaderBytes == 38 && kUdpIpv4HeaderBytes == 28);
static_assert(wire_bytes(3 * 60, 60, kUdpIpv4HeaderBytes) == 180 + 60 * 28);

TEST(EnetTransport, LoopbackRoundTrip) {
    EnetTransport a({.local_id = 0, .bind_host = "127.0.0.1", .port = 0});
    EnetTransport b({.local_id = 1, .bind_host = "127.0.0.1", .port = 0});
    ASSERT_NE(a.port(), 0);
    ASSERT_NE(b.port(), 0);
    ASSERT_NE(a.port(), b.port());

    std::string error;
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port(), &error)) << error;
    EXPECT_FALSE(a.connect(1, "127.0.0.1", b.port(), &error));  // already connecting
    EXPECT_FALSE(a.connect(0, "127.0.0.1", b.port(), &error));  // our own id
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(1) && b.is_connected(0); }, now));
    EXPECT_EQ(a.connected_peers(), std::vector<PeerId>{1});
    EXPECT_EQ(b.connected_peers(), std::vector<PeerId>{0});

    // a -> b: ten datagrams of different sizes (loopback does not lose them).
    constexpr int kCount = 10;
    for (int i = 0; i < kCount; ++i) ASSERT_TRUE(a.send(1, bytes_of(static_cast<std::uint8_t>(i), 1 + 37 * i), now));
    std::vector<Datagram> got;
    ASSERT_TRUE(pump({&b}, [&] {
        Datagram d;
        while (b.receive(d, now)) got.push_back(d);
        return got.size() >= kCount;
    }, now));
    ASSERT_EQ(got.size(), static_cast<std::size_t>(kCount));
    std::vector<bool> seen(kCount, false);
    for (const Datagram& d : got) {
        EXPECT_EQ(d.from, 0u);
        ASSERT_GE(d.bytes.size(), 1u);
        const int i = d.bytes[0];
        ASSERT_LT(i, kCount);
        EXPECT_EQ(d.bytes, bytes_of(static_cast<std::uint8_t>(i), 1 + 37 * i));
        seen[static_cast<std::size_t>(i)] = true;
    }
    for (int i = 0; i < kCount; ++i) EXPECT_TRUE(seen[static_cast<std::size_t>(i)]) << i;

    // b echoes one back: the round trip.
    ASSERT_TRUE(b.send(0, got.front().bytes, now));
    Datagram echo;
    ASSERT_TRUE(pump({&a}, [&] { return a.receive(echo, now); }, now));
    EXPECT_EQ(echo.from, 1u);
    EXPECT_EQ(echo.bytes, got.front().bytes);

    EXPECT_EQ(a.counters().datagrams_sent, static_cast<std::uint64_t>(kCount));
    EXPECT_EQ(b.counters().datagrams_received, static_cast<std::uint64_t>(kCount));
    EXPECT_EQ(a.counters().datagrams_received, 1u);
    EXPECT_EQ(a.service_errors(), 0u);
    EXPECT_EQ(b.service_errors(), 0u);
}

TEST(EnetTransport, RejectsUnknownPeersOversizeAndDuplicateIds) {
    EnetTransport a({.local_id = 0, .port = 0});
    EnetTransport b({.local_id = 1, .port = 0});
    EnetTransport impostor({.local_id = 1, .port = 0});  // claims b's id
    EXPECT_FALSE(a.send(1, bytes_of(0, 4), 0));         // not connected yet
    EXPECT_EQ(a.counters().rejected, 1u);

    ASSERT_TRUE(b.connect(0, "127.0.0.1", a.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &b, &impostor}, [&] { return a.is_connected(1) && b.is_connected(0); }, now));
    ASSERT_TRUE(impostor.connect(0, "127.0.0.1", a.port()));
    // a refuses the second claim to id 1; the first connection is unaffected.
    ASSERT_TRUE(pump({&a, &b, &impostor}, [&] { return a.counters().rejected >= 2; }, now));
    EXPECT_TRUE(a.is_connected(1));
    EXPECT_EQ(a.connected_peers(), std::vector<PeerId>{1});

    EXPECT_FALSE(a.send(1, std::vector<std::uint8_t>(kMaxDatagramBytes + 1), now));
    EXPECT_FALSE(a.send(9, bytes_of(0, 4), now));
    EXPECT_EQ(a.counters().rejected, 4u);
    EXPECT_TRUE(a.send(1, std::vector<std::uint8_t>(kMaxDatagramBytes), now));
    Datagram d;
    ASSERT_TRUE(pump({&b}, [&] { return b.receive(d, now); }, now));
    EXPECT_EQ(d.bytes.size(), kMaxDatagramBytes);
    EXPECT_EQ(d.from, 0u);
}

TEST(EnetTransport, OneSendIsOneDatagramWithTheDocumentedHeader) {
    EnetTransport a({.local_id = 0, .port = 0});
    EnetTransport b({.local_id = 1, .port = 0});
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(1) && b.is_connected(0); }, now));
    for (int i = 0; i < 20; ++i) {  // let handshake acknowledgements drain
        a.poll(now);
        b.poll(now);
    }
    // A send can share its datagram with a pending ENet acknowledgement; the smallest increase
    // over several sends is the bare unsequenced datagram.
    std::uint64_t smallest = ~std::uint64_t{0};
    for (int i = 0; i < 8; ++i) {
        const std::uint64_t before = a.wire_bytes_sent();
        ASSERT_TRUE(a.send(1, bytes_of(1, 100), now));
        smallest = std::min(smallest, a.wire_bytes_sent() - before);
        b.poll(now);
    }
    EXPECT_EQ(smallest, 100u + kEnetHeaderBytes);
    EXPECT_GT(b.wire_bytes_received(), 0u);
}

TEST(EnetTransport, BindFailureNamesTheAddress) {
    EnetTransport a({.local_id = 0, .port = 0});
    try {
        EnetTransport clash({.local_id = 1, .port = a.port()});
        FAIL() << "binding the same port twice should fail";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(std::to_string(a.port())), std::string::npos) << e.what();
    }
}

std::vector<TransportEvent> events_of(EnetTransport& t) {
    std::vector<TransportEvent> out;
    TransportEvent e;
    while (t.next_event(e)) out.push_back(e);
    return out;
}

bool has_event(const std::vector<TransportEvent>& events, TransportEvent::Type type, PeerId peer) {
    return std::any_of(events.begin(), events.end(), [&](const TransportEvent& e) { return e.type == type && e.peer == peer; });
}

TEST(EnetTransport, ReliableChannelDeliversEverythingInOrder) {
    EnetTransport a({.local_id = 0});
    EnetTransport b({.local_id = 1});
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(1) && b.is_connected(0); }, now));
    constexpr int kCount = 60;
    for (int i = 0; i < kCount; ++i) {
        ASSERT_TRUE(a.send_reliable(1, bytes_of(static_cast<std::uint8_t>(i), kMaxDatagramBytes), now));
        ASSERT_TRUE(a.send(1, bytes_of(200, 8), now));  // unreliable ones interleaved
    }
    EXPECT_FALSE(a.send_reliable(1, std::vector<std::uint8_t>(kMaxDatagramBytes + 1), now));
    std::vector<int> reliable_order;
    int unreliable = 0;
    ASSERT_TRUE(pump({&a, &b}, [&] {
        Datagram d;
        while (b.receive(d, now)) {
            if (d.reliable) reliable_order.push_back(d.bytes[0]);
            else ++unreliable;
        }
        return reliable_order.size() >= kCount;
    }, now));
    std::vector<int> expected(kCount);
    for (int i = 0; i < kCount; ++i) expected[static_cast<std::size_t>(i)] = i;
    EXPECT_EQ(reliable_order, expected);
    EXPECT_GT(unreliable, 0);
    // SimNetwork and any transport without a reliable channel: send_reliable is send.
}

TEST(EnetTransport, EventsAndARestartedPeerGetsItsIdBack) {
    EnetTransport a({.local_id = 0});
    Micros now = 0;
    auto b = std::make_unique<EnetTransport>(EnetConfig{.local_id = 1});
    ASSERT_TRUE(b->connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, b.get()}, [&] { return a.is_connected(1) && b->is_connected(0); }, now));
    auto ea = events_of(a);
    EXPECT_TRUE(has_event(ea, TransportEvent::Type::Connected, 1));
    EXPECT_TRUE(has_event(events_of(*b), TransportEvent::Type::Connected, 0));

    // A second live claim to id 1 is refused.
    EnetTransport impostor({.local_id = 1});
    ASSERT_TRUE(impostor.connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, b.get(), &impostor}, [&] { return a.enet_counters().refused_duplicate_id >= 1; }, now));
    EXPECT_TRUE(has_event(events_of(a), TransportEvent::Type::Refused, 1));
    ASSERT_TRUE(pump({&impostor}, [&] { return has_event(events_of(impostor), TransportEvent::Type::Disconnected, 0); }, now));

    // b's process "dies": it stops answering (nothing reaches a any more). A restarted process
    // with id 1 connects after a second of silence and is let in at once as the dead
    // connection's claimant, long before ENet would time it out.
    for (int i = 0; i < 1200; ++i) {  // 1.2 s of a's time (a counter), only a polled
        a.poll(now);
        now += 1'000;
    }
    EnetTransport restarted({.local_id = 1});
    ASSERT_TRUE(restarted.connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return restarted.is_connected(0) && a.enet_counters().replace_claims >= 1; }, now));
    ea = events_of(a);
    ASSERT_TRUE(has_event(ea, TransportEvent::Type::Connected, 1));
    EXPECT_NE(ea.back().reason.find("reconnected"), std::string::npos) << ea.back().reason;
    ASSERT_TRUE(a.send(1, bytes_of(9, 20), now));
    Datagram d;
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return restarted.receive(d, now); }, now));
    EXPECT_EQ(d.bytes, bytes_of(9, 20));
    b.reset();  // the old process closes its connection: the claimant holds id 1 from now on
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return a.enet_counters().replaced >= 1; }, now));
    EXPECT_FALSE(has_event(events_of(a), TransportEvent::Type::Disconnected, 1));

    // ENet's own timeout notices a peer that vanished without a word within seconds (the
    // default would be up to 30 s): freeze `restarted` and keep polling a, for at most ~10 s.
    bool gone = false;
    const auto frozen_at = std::chrono::steady_clock::now();
    for (int i = 0; i < 1000 && !gone; ++i) {
        a.poll(now);
        now += 10'000;
        gone = has_event(events_of(a), TransportEvent::Type::Disconnected, 1);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_TRUE(gone) << "a dead peer was not noticed";
    std::printf("dead peer noticed after %.1f s\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - frozen_at).count());
    EXPECT_FALSE(a.is_connected(1));
    EXPECT_GE(a.enet_counters().disconnects, 1u);
}

TEST(EnetTransport, AnEstablishedConnectionEndsOnlyBySilenceOnTheCallersClock) {
    // ENet's own timeout closed a connection after 3 unacknowledged sends and 2 s of its clock:
    // on a lossy link (30 %, 250 ms) that closed live connections every few seconds. Now only
    // dead_after_us of the caller's time without a word ends an established connection. Here b
    // freezes while a's caller says little time passes: 5 s of real time (ENet used to give up
    // after 3-4 s) and the connection stands; then the caller's clock passes dead_after_us and
    // a reports b gone, saying so.
    EnetTransport a({.local_id = 0, .dead_after_us = 2'000'000});
    EnetTransport b({.local_id = 1});
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(1) && b.is_connected(0); }, now));
    ASSERT_TRUE(b.send(0, bytes_of(7, 8), now));  // a word from b: the link was live
    Datagram d;
    ASSERT_TRUE(pump({&a, &b}, [&] { return a.receive(d, now); }, now));
    const Micros frozen = now;
    for (int i = 0; i < 500; ++i) {  // 5 s of real time, 0.5 s of the caller's
        a.poll(now);
        now += 1'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_TRUE(a.is_connected(1)) << "ENet's own timeout closed an established connection";
    EXPECT_FALSE(has_event(events_of(a), TransportEvent::Type::Disconnected, 1));
    std::vector<TransportEvent> gone;
    ASSERT_TRUE(pump({&a}, [&] {
        for (TransportEvent e; a.next_event(e);) gone.push_back(e);
        return !a.is_connected(1);
    }, now));
    EXPECT_GE(now - frozen, Micros{2'000'000});
    ASSERT_FALSE(gone.empty());
    EXPECT_EQ(gone.back().type, TransportEvent::Type::Disconnected);
    EXPECT_NE(gone.back().reason.find("silent"), std::string::npos) << gone.back().reason;
    EXPECT_EQ(a.enet_counters().disconnects, 1u);
}

TEST(EnetTransport, AConnectionWeOpenedThatNeverHearsAWordIsClosedSoonerAndAnIdleOneStays) {
    // Under loss the accepting side may never get our last handshake acknowledgement and give
    // up, leaving us "connected" to nobody: first_word_after_us of the caller's time without a
    // word since it came up closes it (not dead_after_us), so the runner connects again. Here
    // b freezes the moment a is connected: nothing from b reaches a after the handshake.
    EnetTransport a({.local_id = 0, .dead_after_us = 5'000'000, .first_word_after_us = 1'000'000});
    {
        EnetTransport b({.local_id = 1});
        ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
        Micros now = 0;
        ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(1); }, now));
        const Micros up = now;
        std::vector<TransportEvent> gone;
        ASSERT_TRUE(pump({&a}, [&] {
            for (TransportEvent e; a.next_event(e);)
                if (e.type == TransportEvent::Type::Disconnected) gone.push_back(e);
            return !gone.empty();
        }, now));
        EXPECT_GE(now - up, Micros{1'000'000});
        EXPECT_LT(now - up, Micros{5'000'000}) << "closed only by dead_after_us";
        EXPECT_NE(gone.back().reason.find("not a word since connected"), std::string::npos) << gone.back().reason;
    }
    // A live link that carries nothing of ours is not closed: ENet's pings are answered.
    EnetTransport c({.local_id = 2});
    ASSERT_TRUE(a.connect(2, "127.0.0.1", c.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, &c}, [&] { return a.is_connected(2) && c.is_connected(0); }, now));
    for (int i = 0; i < 1500; ++i) {  // 3 s of both clocks, no datagram sent
        a.poll(now);
        c.poll(now);
        now += 2'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    EXPECT_TRUE(a.is_connected(2) && c.is_connected(0)) << "an idle live link was closed";
}

TEST(EnetTransport, APeerRestartedWithinASecondGetsInOnItsRetry) {
    // 0 connected to 1; 1's process dies and restarts at once, before 0's connection to it has
    // been silent for a second. 0 takes the new connection for the losing half of a crossed
    // connect; the restarted 1 sees Disconnected and retries, and the retry replaces the then
    // silent connection.
    EnetTransport a({.local_id = 0});
    auto old = std::make_unique<EnetTransport>(EnetConfig{.local_id = 1});
    ASSERT_TRUE(a.connect(1, "127.0.0.1", old->port()));
    Micros now = 0;
    ASSERT_TRUE(pump({&a, old.get()}, [&] { return a.is_connected(1) && old->is_connected(0); }, now));

    EnetTransport restarted({.local_id = 1});
    ASSERT_TRUE(restarted.connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return has_event(events_of(restarted), TransportEvent::Type::Disconnected, 0); }, now));
    EXPECT_FALSE(restarted.is_connected(0));
    for (int i = 0; i < 1200; ++i) {  // a second of a's time passes; the old process stays silent
        a.poll(now);
        now += 1'000;
    }
    ASSERT_TRUE(restarted.connect(0, "127.0.0.1", a.port()));
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return restarted.is_connected(0) && a.enet_counters().replace_claims >= 1; }, now));
    ASSERT_TRUE(restarted.send(0, bytes_of(4, 12), now));
    Datagram d;
    ASSERT_TRUE(pump({&a, &restarted}, [&] { return a.receive(d, now); }, now));
    EXPECT_EQ(d.from, 1u);
    EXPECT_EQ(d.bytes, bytes_of(4, 12));
}

// Everything `t` has received from `from` so far, appended to `got`.
void take_all(EnetTransport& t, Micros now, PeerId from, std::vector<std::vector<std::uint8_t>>& got) {
    Datagram d;
    while (t.receive(d, now))
        if (d.from == from) got.push_back(d.bytes);
}

bool received(const std::vector<std::vector<std::uint8_t>>& got, const std::vector<std::uint8_t>& bytes) {
    return std::find(got.begin(), got.end(), bytes) != got.end();
}

TEST(EnetTransport, AnOutsiderClaimingAnIdDuringALossBurstDoesNotCutTheHonestConnection) {
    // Issue 21: an outsider that claimed id 0 while 0's connection had been silent for a second
    // (a loss burst) replaced it at once: the honest process was cut off and never heard again,
    // so the session's rule that a restart claim is void once the old process is heard could
    // not work. Now the claim is provisional: the old connection stays, and when it speaks
    // again it keeps the id and the outsider is dropped.
    EnetTransport honest({.local_id = 0});
    EnetTransport b({.local_id = 1});
    ASSERT_TRUE(honest.connect(1, "127.0.0.1", b.port()));  // the lower id connects, as runners do
    Micros now = 0;
    ASSERT_TRUE(pump({&honest, &b}, [&] { return honest.is_connected(1) && b.is_connected(0); }, now));
    std::vector<std::vector<std::uint8_t>> at_b;
    ASSERT_TRUE(honest.send(1, bytes_of(0xA0, 16), now));
    ASSERT_TRUE(pump({&honest, &b}, [&] { take_all(b, now, 0, at_b); return received(at_b, bytes_of(0xA0, 16)); }, now));
    events_of(honest);
    events_of(b);

    // The loss burst: nothing from the honest process reaches b for 1.2 s of b's time.
    for (int i = 0; i < 1200; ++i) {
        b.poll(now);
        now += 1'000;
    }
    EnetTransport outsider({.local_id = 0});  // claims the honest process's id
    ASSERT_TRUE(outsider.connect(1, "127.0.0.1", b.port()));
    ASSERT_TRUE(pump({&b, &outsider}, [&] { return outsider.is_connected(1) && has_event(events_of(b), TransportEvent::Type::Connected, 0); }, now));
    ASSERT_TRUE(outsider.send(1, bytes_of(0xC0, 16), now));
    ASSERT_TRUE(pump({&b, &outsider}, [&] { take_all(b, now, 0, at_b); return received(at_b, bytes_of(0xC0, 16)); }, now))
        << "the claimant's datagrams are delivered as from the id it claims";
    {  // One claimant at a time: a second claim while the first is live is refused.
        EnetTransport second({.local_id = 0});
        ASSERT_TRUE(second.connect(1, "127.0.0.1", b.port()));
        ASSERT_TRUE(pump({&b, &outsider, &second}, [&] { return b.enet_counters().refused_duplicate_id >= 1; }, now));
        EXPECT_TRUE(has_event(events_of(b), TransportEvent::Type::Refused, 0));
    }

    // The burst ends: the honest process speaks on its old connection, and is heard as 0.
    ASSERT_TRUE(honest.send(1, bytes_of(0xA1, 16), now));
    EXPECT_TRUE(pump({&honest, &b, &outsider}, [&] { take_all(b, now, 0, at_b); return received(at_b, bytes_of(0xA1, 16)); }, now))
        << "the honest process was cut off";
    std::vector<TransportEvent> at_outsider;
    ASSERT_TRUE(pump({&honest, &b, &outsider}, [&] {
        for (TransportEvent e; outsider.next_event(e);) at_outsider.push_back(e);
        return !outsider.is_connected(1);
    }, now)) << "the outsider kept its claim";
    ASSERT_TRUE(has_event(at_outsider, TransportEvent::Type::Disconnected, 1));
    EXPECT_NE(at_outsider.back().reason.find("held by another live connection"), std::string::npos) << at_outsider.back().reason;
    const auto eb = events_of(b);
    const auto refused = std::find_if(eb.begin(), eb.end(), [](const TransportEvent& e) {
        return e.type == TransportEvent::Type::Refused && e.peer == 0;
    });
    ASSERT_NE(refused, eb.end());
    EXPECT_NE(refused->reason.find("id held by a live connection"), std::string::npos) << refused->reason;
    EXPECT_FALSE(has_event(eb, TransportEvent::Type::Disconnected, 0));

    // The honest connection was never touched: no Disconnected ("replaced") on either side,
    // and b's datagrams for 0 reach it.
    for (int i = 0; i < 300; ++i) {  // let anything in flight arrive
        honest.poll(now);
        b.poll(now);
        now += 1'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const auto eh = events_of(honest);
    EXPECT_FALSE(has_event(eh, TransportEvent::Type::Disconnected, 1)) << eh.back().reason;
    EXPECT_TRUE(honest.is_connected(1));
    EXPECT_TRUE(b.is_connected(0));
    ASSERT_TRUE(b.send(0, bytes_of(0xB0, 16), now));
    std::vector<std::vector<std::uint8_t>> at_honest;
    EXPECT_TRUE(pump({&honest, &b}, [&] { take_all(honest, now, 1, at_honest); return received(at_honest, bytes_of(0xB0, 16)); }, now));
    EXPECT_EQ(b.enet_counters().replace_claims, 1u);
    EXPECT_EQ(b.enet_counters().claims_voided, 1u);
    EXPECT_EQ(b.enet_counters().replaced, 0u);
    EXPECT_GE(b.counters().rejected, 1u);
}

TEST(EnetTransport, ARestartedProcessIsHeardAtOnceAndTakesItsIdOverOnceTheOldStaysSilent) {
    // The honest restart under provisional claims: the old process is gone (SIGKILL: it never
    // says another word, not even goodbye). The new one is admitted as soon as the old
    // connection has been silent for silent_after_us and is heard as 0 at once, long before
    // the session's 5 s timeout; when the old connection has been silent for dead_after_us it
    // is closed and the new one holds the id, without a Disconnected in between.
    EnetTransport b({.local_id = 1});
    auto old = std::make_unique<EnetTransport>(EnetConfig{.local_id = 0});
    ASSERT_TRUE(old->connect(1, "127.0.0.1", b.port()));
    Micros now = 0;
    ASSERT_TRUE(pump({old.get(), &b}, [&] { return old->is_connected(1) && b.is_connected(0); }, now));
    std::vector<std::vector<std::uint8_t>> at_b;
    ASSERT_TRUE(old->send(1, bytes_of(0xA0, 16), now));
    ASSERT_TRUE(pump({old.get(), &b}, [&] { take_all(b, now, 0, at_b); return received(at_b, bytes_of(0xA0, 16)); }, now));
    events_of(b);
    const Micros last_word = now;  // b last heard the old process in the poll that got 0xA0

    // Killed: `old` is never polled again. Its replacement dials after b's second of silence.
    for (int i = 0; i < 1200; ++i) {
        b.poll(now);
        now += 1'000;
    }
    EnetTransport restarted({.local_id = 0});
    const Micros dialed = now;
    ASSERT_TRUE(restarted.connect(1, "127.0.0.1", b.port()));
    ASSERT_TRUE(pump({&b, &restarted}, [&] { return restarted.is_connected(1); }, now));
    ASSERT_TRUE(restarted.send(1, bytes_of(0xD1, 16), now));
    ASSERT_TRUE(pump({&b, &restarted}, [&] { take_all(b, now, 0, at_b); return received(at_b, bytes_of(0xD1, 16)); }, now));
    const Micros heard_after = now - dialed;
    EXPECT_LT(heard_after, Micros{1'000'000}) << "the new process was not heard at once";
    std::printf("restarted process heard as its id %.0f ms after it dialed (caller's time)\n", heard_after / 1000.0);
    EXPECT_EQ(b.enet_counters().replace_claims, 1u);
    EXPECT_EQ(b.enet_counters().replaced, 0u);  // the old connection stays until its silence ends it
    ASSERT_TRUE(b.send(0, bytes_of(0xB0, 16), now));
    std::vector<std::vector<std::uint8_t>> at_restarted;
    ASSERT_TRUE(pump({&b, &restarted}, [&] { take_all(restarted, now, 1, at_restarted); return received(at_restarted, bytes_of(0xB0, 16)); }, now))
        << "b's datagrams for 0 do not reach the new process";

    // The old connection stays silent: dead_after_us after it was last heard it is closed, and
    // the new one holds the id. The new process talks all along (every 20 ms of b's time).
    std::vector<TransportEvent> eb;
    for (int i = 0; i < 5'000 && b.enet_counters().replaced == 0; ++i) {
        if (i % 10 == 0) {
            ASSERT_TRUE(restarted.send(1, bytes_of(0xD2, 16), now));
        }
        b.poll(now);
        restarted.poll(now);
        take_all(b, now, 0, at_b);
        take_all(restarted, now, 1, at_restarted);
        for (TransportEvent e; b.next_event(e);) eb.push_back(e);
        now += 2'000;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_EQ(b.enet_counters().replaced, 1u);
    EXPECT_GE(now - last_word, Micros{5'000'000}) << "replaced before the old connection's silence (dead_after_us) ended it";
    EXPECT_FALSE(has_event(eb, TransportEvent::Type::Disconnected, 0));
    EXPECT_FALSE(has_event(eb, TransportEvent::Type::Refused, 0));
    ASSERT_TRUE(has_event(eb, TransportEvent::Type::Connected, 0));
    EXPECT_NE(eb.back().reason.find("the claim stood"), std::string::npos) << eb.back().reason;
    EXPECT_TRUE(b.is_connected(0));
    EXPECT_EQ(b.connected_peers(), std::vector<PeerId>{0});
    EXPECT_EQ(b.enet_counters().claims_voided, 0u);
    ASSERT_TRUE(b.send(0, bytes_of(0xB1, 16), now));
    ASSERT_TRUE(pump({&b, &restarted}, [&] { take_all(restarted, now, 1, at_restarted); return received(at_restarted, bytes_of(0xB1, 16)); }, now));
    EXPECT_FALSE(has_event(events_of(restarted), TransportEvent::Type::Disconnected, 1));
}

TEST(EnetTransport, CrossedConnectsKeepOneConnectionBothWays) {
    for (int round = 0; round < 3; ++round) {
        EnetTransport a({.local_id = 3});
        EnetTransport b({.local_id = 5});
        ASSERT_TRUE(a.connect(5, "127.0.0.1", b.port()));
        ASSERT_TRUE(b.connect(3, "127.0.0.1", a.port()));
        Micros now = 0;
        ASSERT_TRUE(pump({&a, &b}, [&] { return a.is_connected(5) && b.is_connected(3); }, now));
        // Let the losing connection's refusal play out, then check traffic flows both ways.
        for (int i = 0; i < 200; ++i) {
            a.poll(now);
            b.poll(now);
            now += 1'000;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        ASSERT_TRUE(a.is_connected(5) && b.is_connected(3)) << "round " << round;
        EXPECT_GE(a.enet_counters().crossed_connects + b.enet_counters().crossed_connects, 1u);
        EXPECT_EQ(a.counters().rejected + b.counters().rejected, 0u);
        for (int i = 0; i < 10; ++i) {
            ASSERT_TRUE(a.send(5, bytes_of(1, 10), now));
            ASSERT_TRUE(b.send(3, bytes_of(2, 10), now));
        }
        int at_a = 0, at_b = 0;
        pump({&a, &b}, [&] {
            Datagram d;
            while (a.receive(d, now)) at_a += d.from == 5;
            while (b.receive(d, now)) at_b += d.from == 3;
            return at_a >= 10 && at_b >= 10;
        }, now);
        EXPECT_EQ(at_a, 10);
        EXPECT_EQ(at_b, 10);
        EXPECT_FALSE(has_event(events_of(a), TransportEvent::Type::Disconnected, 5));
    }
}

}  // namespace
}  // namespace lockroll::transport
