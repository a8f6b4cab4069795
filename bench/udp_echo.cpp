// udp_echo: the baseline a relay server's CPU is compared with (docs/performance.md, "Density").
// A bare UDP echo on 127.0.0.1: every datagram read with one recvfrom and sent back to its
// sender with one sendto, blocking, nothing else (no protocol, no rooms, no batching): what one
// syscall per datagram costs at a given datagram rate. relay_bench --echo starts it and loads
// it at the rate the server saw, in the same run, so their CPU times are a fair ratio.
//
// With --batch N the same echo batched: one blocking recvmmsg takes whatever has arrived (at
// least one datagram, at most N), one sendmmsg (more if the kernel takes part of the batch)
// sends each back to its own sender, bytes unchanged. Same socket, same datagrams in and out;
// only the syscalls per datagram differ. It is the floor of any relay that sends as many
// datagrams as it receives on this path, batched as lockroll-server batches (its recvmmsg takes
// 64: server/enet_socket_batching.cpp); relay_bench --echo-batch N runs it beside the plain echo.
// With --pass-us P as well, in passes as lockroll-server --pass-interval-us P runs its loop: a
// pass starts at least P µs after the previous one began (sleeping until then), waits for the
// first datagram, and echoes every datagram waiting, N per recvmmsg and sendmmsg, so that the
// datagrams of up to P µs share the syscalls (and the echo adds up to P µs of delay, as the
// server does).
//
// Prints "ready PORT" once bound; exits 0 on SIGTERM / SIGINT, after writing to stderr
// "udp_echo: D datagrams in, E echoed, R receive calls, S send calls" (the test checks them).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {
volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

constexpr std::size_t kMaxDatagram = 4096;
constexpr long kMaxBatch = 1024;  // UIO_MAXIOV: the most one recvmmsg / sendmmsg takes

// A flag's value as an integer in [lo, hi], else a message and exit status 2.
bool parse_int(const char* flag, const char* text, long lo, long hi, long* out) {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno != 0 || v < lo || v > hi) {
        std::fprintf(stderr, "udp_echo: %s: '%s' is not in %ld..%ld\n", flag, text, lo, hi);
        return false;
    }
    *out = v;
    return true;
}

struct Counts {
    unsigned long long in = 0, out = 0, receive_calls = 0, send_calls = 0;
};

// One syscall per datagram: recvfrom, then sendto back to its sender.
void echo_plain(int fd, Counts& c) {
    unsigned char buf[kMaxDatagram];
    while (!g_stop) {
        sockaddr_in from{};
        socklen_t from_len = sizeof from;
        ++c.receive_calls;
        const ssize_t n = recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &from_len);
        if (n < 0) continue;  // EINTR (then g_stop), or a transient error
        ++c.in;
        ++c.send_calls;
        if (sendto(fd, buf, static_cast<std::size_t>(n), 0, reinterpret_cast<sockaddr*>(&from), from_len) >= 0) ++c.out;
    }
}

std::uint64_t monotonic_us() {
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<std::uint64_t>(t.tv_sec) * 1000000u + static_cast<std::uint64_t>(t.tv_nsec) / 1000u;
}

// Batched: one recvmmsg (MSG_WAITFORONE: blocks for the first datagram, then takes only what
// is already queued, up to batch) and sendmmsg of the same headers, each datagram's length and
// sender as received. A datagram the kernel refuses to send (an error on the first of the rest)
// is dropped, as echo_plain drops a failed sendto: never sent twice. With pass_us > 0, passes
// (the header): one starts no sooner than pass_us after the last began, and reads on (without
// waiting) while a read fills the whole batch.
void echo_batched(int fd, std::size_t batch, std::uint64_t pass_us, Counts& c) {
    std::vector<unsigned char> bytes(batch * kMaxDatagram);
    std::vector<iovec> iov(batch);
    std::vector<sockaddr_in> from(batch);
    std::vector<mmsghdr> msgs(batch);
    std::uint64_t last_pass = 0;
    bool more = false;  // the last read filled the batch: in a pass, read on without waiting
    while (!g_stop) {
        if (pass_us > 0 && !more) {
            const std::uint64_t t = monotonic_us();
            if (t < last_pass + pass_us) {
                const timespec wait{0, static_cast<long>((last_pass + pass_us - t) * 1000)};
                nanosleep(&wait, nullptr);
                if (g_stop) break;  // SIGTERM in the sleep: the datagrams have stopped, the read would block for good
            }
            last_pass = monotonic_us();
        }
        for (std::size_t i = 0; i < batch; ++i) {
            iov[i] = {bytes.data() + i * kMaxDatagram, kMaxDatagram};
            msgs[i].msg_hdr = {};
            msgs[i].msg_hdr.msg_name = &from[i];
            msgs[i].msg_hdr.msg_namelen = sizeof from[i];
            msgs[i].msg_hdr.msg_iov = &iov[i];
            msgs[i].msg_hdr.msg_iovlen = 1;
        }
        ++c.receive_calls;
        const int n = recvmmsg(fd, msgs.data(), static_cast<unsigned>(batch), more ? MSG_DONTWAIT : MSG_WAITFORONE, nullptr);
        more = pass_us > 0 && n == static_cast<int>(batch);
        if (n <= 0) continue;  // EINTR (then g_stop), EAGAIN after a full batch, or a transient error
        c.in += static_cast<unsigned>(n);
        // Reply with what arrived: each iovec cut to its datagram's length (msg_namelen as
        // recvmmsg left it).
        for (int i = 0; i < n; ++i) iov[static_cast<std::size_t>(i)].iov_len = msgs[static_cast<std::size_t>(i)].msg_len;
        for (int at = 0; at < n;) {
            ++c.send_calls;
            const int k = sendmmsg(fd, &msgs[static_cast<std::size_t>(at)], static_cast<unsigned>(n - at), 0);
            if (k < 0) {
                if (errno == EINTR) continue;
                ++at;  // the first unsent datagram fails: drop it, send the rest
                continue;
            }
            at += k;
            c.out += static_cast<unsigned>(k);
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    long port = 0, batch = 0, pass_us = 0;
    for (int i = 1; i < argc; ++i) {
        const bool has_value = i + 1 < argc;
        if (std::strcmp(argv[i], "--port") == 0 && has_value) {
            if (!parse_int("--port", argv[++i], 0, 65535, &port)) return 2;
        } else if (std::strcmp(argv[i], "--batch") == 0 && has_value) {
            if (!parse_int("--batch", argv[++i], 1, kMaxBatch, &batch)) return 2;
        } else if (std::strcmp(argv[i], "--pass-us") == 0 && has_value) {
            if (!parse_int("--pass-us", argv[++i], 0, 100000, &pass_us)) return 2;
        } else {
            std::fprintf(stderr, "usage: udp_echo [--port N] [--batch N [--pass-us P]]   (127.0.0.1; port 0: any free port; batch "
                                 "1..%ld: recvmmsg / sendmmsg of up to N, else one syscall per datagram; pass-us: passes at most "
                                 "one per P µs)\n", kMaxBatch);
            return 2;
        }
    }
    if (pass_us > 0 && batch == 0) {
        std::fprintf(stderr, "udp_echo: --pass-us needs --batch (passes batch the datagrams they find)\n");
        return 2;
    }
    struct sigaction sa {};
    sa.sa_handler = on_signal;  // no SA_RESTART: a blocked receive returns EINTR and the loop ends
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
        std::fprintf(stderr, "udp_echo: cannot bind 127.0.0.1:%ld: %s\n", port, std::strerror(errno));
        return 1;
    }
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    std::printf("ready %u\n", ntohs(a.sin_port));
    std::fflush(stdout);
    Counts c;
    if (batch > 0)
        echo_batched(fd, static_cast<std::size_t>(batch), static_cast<std::uint64_t>(pass_us), c);
    else
        echo_plain(fd, c);
    close(fd);
    std::fprintf(stderr, "udp_echo: %llu datagrams in, %llu echoed, %llu receive calls, %llu send calls\n", c.in, c.out,
                 c.receive_calls, c.send_calls);
    return 0;
}
