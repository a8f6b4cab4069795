#include "harness/live/free_ports.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <random>
#include <stdexcept>

namespace lockroll::harness {

namespace {
// Ports below this are left alone (well-known and registered services live low).
constexpr int kLowest = 10000;

// Binds a UDP socket to 127.0.0.1:port; returns the descriptor, or -1 when the port is taken.
int bind_loopback(int port) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) return -1;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        ::close(fd);
        return -1;
    }
    return fd;
}
}  // namespace

std::uint16_t ephemeral_port_floor() {
    std::ifstream f("/proc/sys/net/ipv4/ip_local_port_range");
    int low = 0, high = 0;
    if (f >> low >> high && low > kLowest && low <= 65535) return static_cast<std::uint16_t>(low);
    return 32768;
}

std::vector<std::uint16_t> free_loopback_ports(int n) {
    const int floor = ephemeral_port_floor();
    const int span = floor - kLowest;
    std::vector<int> fds;
    std::vector<std::uint16_t> ports;
    const int start = static_cast<int>(std::random_device{}() % static_cast<unsigned>(span));
    for (int k = 0; k < span && static_cast<int>(ports.size()) < n; ++k) {
        const int port = kLowest + (start + k) % span;
        const int fd = bind_loopback(port);
        if (fd < 0) continue;
        fds.push_back(fd);
        ports.push_back(static_cast<std::uint16_t>(port));
    }
    for (int fd : fds) ::close(fd);
    if (static_cast<int>(ports.size()) < n)
        throw std::runtime_error("cannot find " + std::to_string(n) + " free UDP ports on 127.0.0.1 below " +
                                 std::to_string(floor));
    return ports;
}

}  // namespace lockroll::harness
