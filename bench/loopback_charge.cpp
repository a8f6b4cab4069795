// loopback_charge: on 127.0.0.1, which process's CPU pays for a datagram's delivery?
//
// docs/performance.md ("Density") compares the relay server's CPU with a bare UDP echo's on
// loopback. The claim checked here: on loopback the kernel delivers a datagram (IP, UDP, the
// receiver's queue and its wake-up) inside the sender's sendto / sendmmsg, so the sender's
// kernel time carries the delivery and the receiver's only its read. A sender process and a
// receiver process (forked, each pinned to its own CPU when there are two) move N datagrams of
// 40 bytes at a paced rate (bursts every millisecond, as a relay server's passes), one syscall
// per datagram or batched (sendmmsg / recvmmsg of 64); each reports its own utime and stime
// (getrusage) per datagram. Not a test: run by hand, e.g.
//   build/bench/loopback_charge --datagrams 600000 --rate 120000
// Loopback only.
#include <netinet/in.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

constexpr std::size_t kPayload = 40;
constexpr unsigned kBatch = 64;

double cpu_us(const timeval& t) { return static_cast<double>(t.tv_sec) * 1e6 + static_cast<double>(t.tv_usec); }

void pin(int cpu) {
    if (cpu < 0) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    sched_setaffinity(0, sizeof set, &set);
}

std::uint64_t now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

struct Result {
    double user_us = 0, sys_us = 0;
    std::uint64_t datagrams = 0;
};

// Reads until the 1-byte end marker; reports through the pipe.
void receiver(int sock, bool batched, int out_fd, int cpu) {
    pin(cpu);
    std::vector<std::uint8_t> bytes(kBatch * 2048);
    std::vector<mmsghdr> headers(kBatch);
    std::vector<iovec> iov(kBatch);
    for (unsigned i = 0; i < kBatch; ++i) {
        iov[i] = {&bytes[i * 2048], 2048};
        headers[i] = {};
        headers[i].msg_hdr.msg_iov = &iov[i];
        headers[i].msg_hdr.msg_iovlen = 1;
    }
    Result r;
    bool done = false;
    while (!done) {
        if (batched) {
            const int n = recvmmsg(sock, headers.data(), kBatch, MSG_WAITFORONE, nullptr);
            for (int i = 0; i < n; ++i) {
                if (headers[static_cast<std::size_t>(i)].msg_len == 1) done = true;
                else ++r.datagrams;
            }
        } else {
            const ssize_t n = recv(sock, bytes.data(), bytes.size(), 0);
            if (n == 1) done = true;
            else if (n > 0) ++r.datagrams;
        }
    }
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    r.user_us = cpu_us(u.ru_utime);
    r.sys_us = cpu_us(u.ru_stime);
    if (write(out_fd, &r, sizeof r) != static_cast<ssize_t>(sizeof r)) std::exit(1);
    std::exit(0);
}

Result sender(int sock, const sockaddr_in& to, bool batched, std::uint64_t count, double rate, int cpu) {
    pin(cpu);
    std::uint8_t payload[kPayload] = {};
    std::vector<mmsghdr> headers(kBatch);
    iovec iov{payload, kPayload};
    for (auto& h : headers) {
        h = {};
        h.msg_hdr.msg_name = const_cast<sockaddr_in*>(&to);
        h.msg_hdr.msg_namelen = sizeof to;
        h.msg_hdr.msg_iov = &iov;
        h.msg_hdr.msg_iovlen = 1;
    }
    const auto per_ms = static_cast<std::uint64_t>(rate / 1000.0);
    const std::uint64_t start = now_ns();
    std::uint64_t sent = 0;
    for (std::uint64_t ms = 0; sent < count; ++ms) {
        while (now_ns() < start + ms * 1'000'000ull) {
            const timespec nap{0, 50'000};
            nanosleep(&nap, nullptr);
        }
        std::uint64_t burst = std::min<std::uint64_t>(per_ms, count - sent);
        while (burst > 0) {
            if (batched) {
                const unsigned k = static_cast<unsigned>(std::min<std::uint64_t>(burst, kBatch));
                const int n = sendmmsg(sock, headers.data(), k, 0);
                if (n <= 0) continue;
                burst -= static_cast<std::uint64_t>(n);
                sent += static_cast<std::uint64_t>(n);
            } else {
                if (sendto(sock, payload, kPayload, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) == static_cast<ssize_t>(kPayload)) {
                    --burst;
                    ++sent;
                }
            }
        }
    }
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    Result r;
    r.user_us = cpu_us(u.ru_utime);
    r.sys_us = cpu_us(u.ru_stime);
    r.datagrams = sent;
    return r;
}

void run(bool send_batched, bool receive_batched, std::uint64_t count, double rate) {
    const int rx = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof to;
    const int big = 16 << 20;
    setsockopt(rx, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    if (bind(rx, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0 || getsockname(rx, reinterpret_cast<sockaddr*>(&to), &len) != 0) {
        std::perror("loopback_charge: bind");
        std::exit(1);
    }
    int pipe_fd[2];
    if (pipe(pipe_fd) != 0) std::exit(1);
    const int two = sysconf(_SC_NPROCESSORS_ONLN) >= 2;
    std::fflush(stdout);  // the child must not print the parent's buffer again
    const pid_t child = fork();
    if (child == 0) {
        close(pipe_fd[0]);
        receiver(rx, receive_batched, pipe_fd[1], two ? 1 : -1);
    }
    close(pipe_fd[1]);
    const int tx = socket(AF_INET, SOCK_DGRAM, 0);
    rusage before{};
    getrusage(RUSAGE_SELF, &before);
    Result s = sender(tx, to, send_batched, count, rate, two ? 0 : -1);
    s.user_us -= cpu_us(before.ru_utime);
    s.sys_us -= cpu_us(before.ru_stime);
    const std::uint8_t end = 0;
    for (int i = 0; i < 50; ++i) sendto(tx, &end, 1, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    Result r;
    if (read(pipe_fd[0], &r, sizeof r) != static_cast<ssize_t>(sizeof r)) std::exit(1);
    waitpid(child, nullptr, 0);
    close(tx);
    close(rx);
    auto ns = [](double us, std::uint64_t n) { return n ? us * 1000.0 / static_cast<double>(n) : 0.0; };
    std::printf("%-9s -> %-9s  sender: user %6.0f sys %6.0f ns/datagram   receiver: user %6.0f sys %6.0f ns/datagram   (%llu sent, %llu read)\n",
                send_batched ? "sendmmsg" : "sendto", receive_batched ? "recvmmsg" : "recv", ns(s.user_us, s.datagrams),
                ns(s.sys_us, s.datagrams), ns(r.user_us, r.datagrams), ns(r.sys_us, r.datagrams),
                static_cast<unsigned long long>(s.datagrams), static_cast<unsigned long long>(r.datagrams));
}

}  // namespace

int main(int argc, char** argv) {
    std::uint64_t count = 600000;
    double rate = 120000;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i];
        if (a == "--datagrams") count = std::strtoull(argv[i + 1], nullptr, 10);
        else if (a == "--rate") rate = std::strtod(argv[i + 1], nullptr);
        else {
            std::fprintf(stderr, "usage: loopback_charge [--datagrams N] [--rate PER_S]\n");
            return 2;
        }
    }
    if (count == 0 || !(rate >= 1000)) {
        std::fprintf(stderr, "loopback_charge: --datagrams >= 1, --rate >= 1000\n");
        return 2;
    }
    std::printf("loopback_charge: %llu datagrams of %zu bytes at %.0f/s, 127.0.0.1, sender and receiver in two processes\n",
                static_cast<unsigned long long>(count), kPayload, rate);
    run(false, false, count, rate);
    run(true, false, count, rate);
    run(false, true, count, rate);
    run(true, true, count, rate);
    return 0;
}
