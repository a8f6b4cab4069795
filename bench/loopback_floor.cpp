// What the kernel alone charges for one datagram's life on loopback (send, delivery, receive),
// one syscall per datagram as ENet does, and batched with sendmmsg/recvmmsg. This is the floor
// under the relay server's cost per relayed datagram (docs/performance.md, "Relay server"):
// no ENet, no relay logic, 100-byte payloads (a relay Frames message is 40-120 bytes).
// Google Benchmark's CPU time of the thread includes the time spent in those syscalls.
#include <benchmark/benchmark.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>

namespace {

constexpr int kBatch = 32;
constexpr std::size_t kPayload = 100;

struct LoopbackPair {
    int from = -1, to = -1;
    sockaddr_in to_addr{};
    LoopbackPair() {
        from = ::socket(AF_INET, SOCK_DGRAM, 0);
        to = ::socket(AF_INET, SOCK_DGRAM, 0);
        to_addr.sin_family = AF_INET;
        to_addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t len = sizeof to_addr;
        if (::bind(to, reinterpret_cast<sockaddr*>(&to_addr), sizeof to_addr) != 0 ||
            ::getsockname(to, reinterpret_cast<sockaddr*>(&to_addr), &len) != 0)
            throw std::runtime_error("loopback_floor: cannot bind 127.0.0.1");
        const int big = 8 << 20;
        ::setsockopt(to, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    }
    ~LoopbackPair() {
        ::close(from);
        ::close(to);
    }
};

void BM_OneSyscallPerDatagram(benchmark::State& state) {
    LoopbackPair p;
    std::array<std::uint8_t, kPayload> out{}, in{};
    std::int64_t moved = 0;
    for (auto _ : state) {
        for (int k = 0; k < kBatch; ++k)
            ::sendto(p.from, out.data(), out.size(), 0, reinterpret_cast<const sockaddr*>(&p.to_addr), sizeof p.to_addr);
        for (int k = 0; k < kBatch; ++k) moved += ::recv(p.to, in.data(), in.size(), MSG_DONTWAIT) > 0;
    }
    state.SetItemsProcessed(moved);
}

void BM_Batched(benchmark::State& state) {
    LoopbackPair p;
    std::array<std::array<std::uint8_t, kPayload>, kBatch> bufs{};
    std::array<iovec, kBatch> iov{};
    std::array<mmsghdr, kBatch> send_h{}, recv_h{};
    for (int k = 0; k < kBatch; ++k) {
        iov[k] = {bufs[k].data(), kPayload};
        send_h[k].msg_hdr.msg_iov = &iov[k];
        send_h[k].msg_hdr.msg_iovlen = 1;
        send_h[k].msg_hdr.msg_name = &p.to_addr;
        send_h[k].msg_hdr.msg_namelen = sizeof p.to_addr;
        recv_h[k].msg_hdr.msg_iov = &iov[k];
        recv_h[k].msg_hdr.msg_iovlen = 1;
    }
    std::int64_t moved = 0;
    for (auto _ : state) {
        ::sendmmsg(p.from, send_h.data(), kBatch, 0);
        const int got = ::recvmmsg(p.to, recv_h.data(), kBatch, MSG_DONTWAIT, nullptr);
        moved += got > 0 ? got : 0;
    }
    state.SetItemsProcessed(moved);
}

BENCHMARK(BM_OneSyscallPerDatagram);
BENCHMARK(BM_Batched);

}  // namespace

BENCHMARK_MAIN();
