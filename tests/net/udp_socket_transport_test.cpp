// UdpSocketTransport (examples/counter's own transport over plain UDP sockets): a connect() makes a peer
// reachable at once, the other side learns it from its first datagram, and an id is taken only
// from the address it was first heard from (spoofs, our own id, short datagrams: dropped).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <vector>

#include "udp_socket_transport.h"

namespace example {
namespace {

namespace transport = lockroll::transport;

using transport::Datagram;
using transport::TransportEvent;

// Receives for up to a second (loopback delivers in microseconds; the bound is for a loaded box).
bool receive_within_a_second(UdpSocketTransport& t, Datagram& out) {
    for (int i = 0; i < 1000; ++i) {
        if (t.receive(out, 42)) return true;
        usleep(1000);
    }
    return false;
}

// A raw datagram to 127.0.0.1:port from a socket of its own (another address than any peer's).
void send_raw(std::uint16_t port, const std::vector<std::uint8_t>& bytes) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a);
    ::close(fd);
}

TEST(UdpSocketTransport, ConnectThenTheOtherSideLearnsTheSenderFromItsFirstDatagram) {
    UdpSocketTransport a(0, 0, 4), b(1, 0, 4);
    EXPECT_FALSE(a.is_connected(1));
    EXPECT_FALSE(a.send(1, std::vector<std::uint8_t>{1}, 0));  // nowhere to send yet
    std::string error;
    EXPECT_FALSE(a.connect(1, "localhost", b.port(), &error));
    EXPECT_NE(error.find("numeric"), std::string::npos);
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    EXPECT_TRUE(a.is_connected(1));
    TransportEvent e;
    ASSERT_TRUE(a.next_event(e));
    EXPECT_EQ(e.type, TransportEvent::Type::Connected);
    EXPECT_EQ(e.peer, 1u);
    ASSERT_TRUE(a.send(1, std::vector<std::uint8_t>{7, 8, 9}, 0));
    Datagram d;
    ASSERT_TRUE(receive_within_a_second(b, d));
    EXPECT_EQ(d.from, 0u);
    EXPECT_EQ(d.time_us, 42u);
    EXPECT_EQ(d.bytes, (std::vector<std::uint8_t>{7, 8, 9}));
    ASSERT_TRUE(b.next_event(e));
    EXPECT_EQ(e.peer, 0u);
    EXPECT_TRUE(b.is_connected(0));
    // And back, to the address it was heard from.
    ASSERT_TRUE(b.send(0, std::vector<std::uint8_t>{5}, 0));
    ASSERT_TRUE(receive_within_a_second(a, d));
    EXPECT_EQ(d.from, 1u);
    EXPECT_EQ(a.counters().datagrams_received, 1u);
}

TEST(UdpSocketTransport, AnIdIsTakenOnlyFromTheAddressItWasFirstHeardFrom) {
    UdpSocketTransport a(0, 0, 4), b(1, 0, 4);
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    ASSERT_TRUE(a.send(1, std::vector<std::uint8_t>{1}, 0));
    Datagram d;
    ASSERT_TRUE(receive_within_a_second(b, d));
    send_raw(b.port(), {0, 0, 0, 0, 66});   // claims id 0 from another address
    send_raw(b.port(), {1, 0, 0, 0, 66});   // claims b's own id
    send_raw(b.port(), {9, 0, 0, 0, 66});   // an id out of range
    send_raw(b.port(), {0, 0});             // shorter than an id
    ASSERT_TRUE(a.send(1, std::vector<std::uint8_t>{2}, 0));  // the real peer still gets through
    ASSERT_TRUE(receive_within_a_second(b, d));
    EXPECT_EQ(d.bytes, (std::vector<std::uint8_t>{2}));
    EXPECT_EQ(b.counters().rejected, 4u);
    EXPECT_EQ(b.counters().datagrams_received, 2u);
}

TEST(UdpSocketTransport, OversizedSendsAreRefused) {
    UdpSocketTransport a(0, 0, 2), b(1, 0, 2);
    ASSERT_TRUE(a.connect(1, "127.0.0.1", b.port()));
    EXPECT_FALSE(a.send(1, std::vector<std::uint8_t>(transport::kMaxDatagramBytes + 1), 0));
    EXPECT_TRUE(a.send(1, std::vector<std::uint8_t>(transport::kMaxDatagramBytes), 0));
    EXPECT_EQ(a.counters().rejected, 1u);
}

}  // namespace
}  // namespace example
