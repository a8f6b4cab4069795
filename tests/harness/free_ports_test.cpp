// harness/live/free_ports.h: distinct ports below the ephemeral range, each free when returned.
#include "harness/live/free_ports.h"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <set>

namespace lockroll::harness {
namespace {

bool bindable(std::uint16_t port) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(port);
    const bool ok = fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    if (fd >= 0) ::close(fd);
    return ok;
}

TEST(FreePorts, DistinctFreeAndBelowTheEphemeralRange) {
    const auto ports = free_loopback_ports(12);
    ASSERT_EQ(ports.size(), 12u);
    EXPECT_EQ(std::set<std::uint16_t>(ports.begin(), ports.end()).size(), 12u);
    for (std::uint16_t p : ports) {
        EXPECT_GE(p, 10000);
        EXPECT_LT(p, ephemeral_port_floor());
        EXPECT_TRUE(bindable(p)) << p;
    }
}

TEST(FreePorts, SkipsAPortThatIsTaken) {
    // Hold every port the first call returned: the next call must find others.
    const auto first = free_loopback_ports(4);
    std::vector<int> held;
    for (std::uint16_t p : first) {
        const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = htons(p);
        ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
        held.push_back(fd);
    }
    for (int k = 0; k < 20; ++k)
        for (std::uint16_t p : free_loopback_ports(4)) EXPECT_TRUE(bindable(p)) << p;
    for (int fd : held) ::close(fd);
}

TEST(FreePorts, AskingForMoreThanThereAreThrows) {
    EXPECT_THROW(free_loopback_ports(70000), std::runtime_error);
}

}  // namespace
}  // namespace lockroll::harness
