// DatagramBatch on two real UDP sockets on 127.0.0.1 (one process): every datagram arrives, in
// order, byte for byte, with far fewer syscalls than datagrams; oversized ones are dropped and
// counted; a full send queue flushes itself.
#include "server/datagram_batch.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace lockroll::server {
namespace {

struct Socket {
    int fd = -1;
    sockaddr_in address{};
    Socket() {
        fd = socket(AF_INET, SOCK_DGRAM, 0);
        address.sin_family = AF_INET;
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        address.sin_port = 0;
        EXPECT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
        socklen_t len = sizeof address;
        getsockname(fd, reinterpret_cast<sockaddr*>(&address), &len);
        const int big = 4 << 20;
        setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    }
    ~Socket() { close(fd); }
    bool readable() const {
        pollfd p{fd, POLLIN, 0};
        return poll(&p, 1, 2000) == 1;  // bounded: loopback delivers before sendto returns
    }
};

std::vector<std::uint8_t> payload(int i, std::size_t n) {
    std::vector<std::uint8_t> b(n);
    for (std::size_t k = 0; k < n; ++k) b[k] = static_cast<std::uint8_t>(i * 7 + static_cast<int>(k));
    return b;
}

TEST(DatagramBatch, SendsEveryQueuedDatagramInOneSyscall) {
    Socket a, b;
    DatagramBatch batch(a.fd);
    for (int i = 0; i < 100; ++i) {
        auto head = payload(i, 4), body = payload(i + 1000, 20 + static_cast<std::size_t>(i));
        const iovec parts[2] = {{head.data(), head.size()}, {body.data(), body.size()}};
        EXPECT_EQ(batch.send(b.address, parts, 2), static_cast<int>(24 + i));
    }
    EXPECT_EQ(batch.queued(), 100u);
    EXPECT_EQ(batch.counters().send_calls, 0u);  // nothing leaves before flush
    batch.flush();
    EXPECT_EQ(batch.counters().send_calls, 1u);
    EXPECT_EQ(batch.counters().datagrams_out, 100u);
    EXPECT_EQ(batch.queued(), 0u);
    for (int i = 0; i < 100; ++i) {
        ASSERT_TRUE(b.readable());
        std::uint8_t buf[256];
        sockaddr_in from{};
        socklen_t len = sizeof from;
        const ssize_t n = recvfrom(b.fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &len);
        ASSERT_EQ(n, 24 + i);
        auto head = payload(i, 4), body = payload(i + 1000, 20 + static_cast<std::size_t>(i));
        EXPECT_TRUE(std::equal(head.begin(), head.end(), buf));
        EXPECT_TRUE(std::equal(body.begin(), body.end(), buf + 4));
        EXPECT_EQ(from.sin_port, a.address.sin_port);
    }
}

TEST(DatagramBatch, ReceivesInBatchesInOrder) {
    Socket a, b;
    for (int i = 0; i < 150; ++i) {
        auto p = payload(i, 10 + static_cast<std::size_t>(i % 50));
        ASSERT_EQ(sendto(a.fd, p.data(), p.size(), 0, reinterpret_cast<const sockaddr*>(&b.address), sizeof b.address),
                  static_cast<ssize_t>(p.size()));
    }
    ASSERT_TRUE(b.readable());
    DatagramBatch batch(b.fd, 64, 8);
    for (int i = 0; i < 150; ++i) {
        std::uint8_t buf[128];
        const iovec into{buf, sizeof buf};
        sockaddr_in from{};
        const int n = batch.receive(from, &into, 1);
        ASSERT_EQ(n, 10 + i % 50) << "datagram " << i;
        auto p = payload(i, static_cast<std::size_t>(n));
        EXPECT_TRUE(std::equal(p.begin(), p.end(), buf));
        EXPECT_EQ(from.sin_port, a.address.sin_port);
    }
    EXPECT_EQ(batch.counters().receive_calls, 3u);  // 64 + 64 + 22
    EXPECT_FALSE(batch.has_buffered());
    std::uint8_t buf[16];
    const iovec into{buf, sizeof buf};
    sockaddr_in from{};
    EXPECT_EQ(batch.receive(from, &into, 1), 0);  // nothing waits: 0, as ENet's receive
    EXPECT_EQ(batch.counters().datagrams_in, 150u);
}

TEST(DatagramBatch, CutsADatagramToTheCallersBuffersAsRecvmsgDoes) {
    Socket a, b;
    auto p = payload(3, 100);
    sendto(a.fd, p.data(), p.size(), 0, reinterpret_cast<const sockaddr*>(&b.address), sizeof b.address);
    ASSERT_TRUE(b.readable());
    DatagramBatch batch(b.fd);
    std::uint8_t x[30], y[30];
    const iovec into[2] = {{x, sizeof x}, {y, sizeof y}};
    sockaddr_in from{};
    EXPECT_EQ(batch.receive(from, into, 2), 60);
    EXPECT_TRUE(std::equal(p.begin(), p.begin() + 30, x));
    EXPECT_TRUE(std::equal(p.begin() + 30, p.begin() + 60, y));
}

TEST(DatagramBatch, DropsAndCountsOversizedDatagrams) {
    Socket a, b;
    std::vector<std::uint8_t> big(DatagramBatch::kMaxBytes + 100, 1), small(8, 2);
    sendto(a.fd, big.data(), big.size(), 0, reinterpret_cast<const sockaddr*>(&b.address), sizeof b.address);
    sendto(a.fd, small.data(), small.size(), 0, reinterpret_cast<const sockaddr*>(&b.address), sizeof b.address);
    ASSERT_TRUE(b.readable());
    DatagramBatch batch(b.fd);
    std::uint8_t buf[8192];
    const iovec into{buf, sizeof buf};
    sockaddr_in from{};
    EXPECT_EQ(batch.receive(from, &into, 1), 8);  // the oversized one is skipped, not an error
    EXPECT_EQ(batch.counters().dropped_oversized, 1u);
    // and one too long to send is refused, nothing queued
    const iovec out{big.data(), big.size()};
    EXPECT_EQ(batch.send(b.address, &out, 1), -1);
    EXPECT_EQ(batch.queued(), 0u);
}

TEST(DatagramBatch, AFullQueueFlushesItself) {
    Socket a, b;
    DatagramBatch batch(a.fd, 4, 16);
    std::uint8_t byte = 9;
    const iovec one{&byte, 1};
    for (int i = 0; i < 40; ++i) ASSERT_EQ(batch.send(b.address, &one, 1), 1);
    EXPECT_EQ(batch.counters().send_calls, 2u);  // at 16 and 32 queued
    EXPECT_EQ(batch.queued(), 8u);
    batch.flush();
    EXPECT_EQ(batch.counters().datagrams_out, 40u);
    int got = 0;
    while (got < 40 && b.readable()) {
        std::uint8_t buf[4];
        if (recv(b.fd, buf, sizeof buf, 0) == 1) ++got;
    }
    EXPECT_EQ(got, 40);
}

TEST(DatagramBatch, RefusesZeroSlots) { EXPECT_THROW(DatagramBatch(0, 0, 1), std::invalid_argument); }

}  // namespace
}  // namespace lockroll::server
