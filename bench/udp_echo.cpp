// udp_echo: the baseline a relay server's CPU is compared with (docs/performance.md, "Density").
// A bare UDP echo on 127.0.0.1: every datagram read with one recvfrom and sent back to its
// sender with one sendto, blocking, nothing else (no protocol, no rooms, no batching): what one
// syscall per datagram costs at a given datagram rate. relay_bench --echo starts it and loads
// it at the rate the server saw, in the same run, so their CPU times are a fair ratio.
// Prints "ready PORT" once bound; exits 0 on SIGTERM / SIGINT.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace {
volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
    int port = 0;
    if (argc == 3 && std::strcmp(argv[1], "--port") == 0) {
        char* end = nullptr;
        const long p = std::strtol(argv[2], &end, 10);
        if (end == argv[2] || *end != '\0' || p < 0 || p > 65535) {
            std::fprintf(stderr, "udp_echo: --port: '%s' is not a port (0..65535)\n", argv[2]);
            return 2;
        }
        port = static_cast<int>(p);
    } else if (argc != 1) {
        std::fprintf(stderr, "usage: udp_echo [--port N]   (127.0.0.1; 0: any free port)\n");
        return 2;
    }
    struct sigaction sa {};
    sa.sa_handler = on_signal;  // no SA_RESTART: a blocked recvfrom returns EINTR and the loop ends
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    const int fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    const int big = 4 << 20;  // as lockroll-server's socket (transport/enet_server.h)
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        std::fprintf(stderr, "udp_echo: cannot bind 127.0.0.1:%d: %s\n", port, std::strerror(errno));
        return 1;
    }
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    std::printf("ready %u\n", ntohs(a.sin_port));
    std::fflush(stdout);
    unsigned char buf[4096];
    while (!g_stop) {
        sockaddr_in from{};
        socklen_t from_len = sizeof from;
        const ssize_t n = recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &from_len);
        if (n < 0) continue;  // EINTR (then g_stop), or a transient error
        sendto(fd, buf, static_cast<std::size_t>(n), 0, reinterpret_cast<sockaddr*>(&from), from_len);
    }
    close(fd);
    return 0;
}
