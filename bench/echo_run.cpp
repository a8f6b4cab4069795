#include "bench/echo_run.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <vector>

#include "bench/child_process.h"

namespace lockroll::bench {

EchoResult run_echo(const Options& o, double rate, int batch, const std::string& dir) {
    static int runs = 0;
    std::vector<std::string> args{o.echo};
    if (batch > 0) args.insert(args.end(), {"--batch", std::to_string(batch)});
    if (batch > 0 && o.echo_pass_us > 0) args.insert(args.end(), {"--pass-us", std::to_string(o.echo_pass_us)});
    const std::string log = dir + "/echo-" + std::to_string(runs++) + ".log";
    const ServerChild echo = spawn_ready(o, args, log);
    EchoResult res;
    const int hosts = std::max(1, o.hosts);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(echo.port);
    const int ep = epoll_create1(EPOLL_CLOEXEC);
    std::vector<int> fds;
    for (int h = 0; h < hosts; ++h) {
        const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK, 0);
        const int big = 1 << 20;
        setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.u32 = static_cast<std::uint32_t>(h);
        epoll_ctl(ep, EPOLL_CTL_ADD, fd, &ev);
        fds.push_back(fd);
    }
    std::array<std::uint8_t, 40> payload{};  // about a relay input with ENet's headers
    std::vector<iovec> iov(4096, iovec{payload.data(), payload.size()});
    std::vector<mmsghdr> out(4096), in(256);
    std::vector<std::array<std::uint8_t, 64>> in_bytes(in.size());
    std::vector<iovec> in_iov(in.size());
    const double per_fire = rate / kTickRate / hosts;
    std::vector<double> owed(static_cast<std::size_t>(hosts), 0);
    const std::uint64_t start = now_us(), window_start = start + 1'000'000;
    const std::uint64_t window_end = window_start + static_cast<std::uint64_t>(o.seconds * 1e6);
    std::vector<std::uint64_t> next_fire(static_cast<std::size_t>(hosts));
    for (int h = 0; h < hosts; ++h) next_fire[static_cast<std::size_t>(h)] = start + kPeriodUs * static_cast<std::uint64_t>(h) / static_cast<std::uint64_t>(hosts);
    std::uint64_t sent = 0, received = 0, sent0 = 0, received0 = 0;
    double cpu0 = 0, sys0 = 0;
    bool measuring = false;
    std::vector<epoll_event> ready(static_cast<std::size_t>(hosts));
    for (;;) {
        const std::uint64_t now = now_us();
        if (!measuring && now >= window_start) {
            measuring = true;
            cpu0 = process_cpu_s(echo.pid, &sys0);
            sent0 = sent;
            received0 = received;
        }
        if (now >= window_end) break;
        for (int h = 0; h < hosts; ++h) {
            auto& nf = next_fire[static_cast<std::size_t>(h)];
            while (now >= nf) {
                owed[static_cast<std::size_t>(h)] += per_fire;
                const auto n = std::min<std::size_t>(out.size(), static_cast<std::size_t>(owed[static_cast<std::size_t>(h)]));
                owed[static_cast<std::size_t>(h)] -= static_cast<double>(n);
                for (std::size_t i = 0; i < n; ++i) {
                    out[i].msg_hdr = {};
                    out[i].msg_hdr.msg_name = &to;
                    out[i].msg_hdr.msg_namelen = sizeof to;
                    out[i].msg_hdr.msg_iov = &iov[i];
                    out[i].msg_hdr.msg_iovlen = 1;
                }
                for (std::size_t at = 0; at < n;) {
                    const int k = sendmmsg(fds[static_cast<std::size_t>(h)], &out[at], static_cast<unsigned>(n - at), 0);
                    if (k <= 0) break;  // the echo's buffer is full: what was not sent is lost, as UDP
                    at += static_cast<std::size_t>(k);
                    sent += static_cast<std::uint64_t>(k);
                }
                nf += kPeriodUs;
            }
        }
        const std::uint64_t wake = *std::min_element(next_fire.begin(), next_fire.end());
        const std::uint64_t t = now_us();
        const std::uint64_t wait_us = wake > t ? std::min<std::uint64_t>(wake - t, 999'999) : 0;
        const timespec ts{0, static_cast<long>(wait_us * 1000)};
        const int n = epoll_pwait2(ep, ready.data(), hosts, &ts, nullptr);
        for (int i = 0; i < n; ++i) {
            const int fd = fds[ready[static_cast<std::size_t>(i)].data.u32];
            for (;;) {
                for (std::size_t j = 0; j < in.size(); ++j) {
                    in_iov[j] = {in_bytes[j].data(), in_bytes[j].size()};
                    in[j].msg_hdr = {};
                    in[j].msg_hdr.msg_iov = &in_iov[j];
                    in[j].msg_hdr.msg_iovlen = 1;
                }
                const int k = recvmmsg(fd, in.data(), static_cast<unsigned>(in.size()), MSG_DONTWAIT, nullptr);
                if (k <= 0) break;
                received += static_cast<std::uint64_t>(k);
            }
        }
    }
    const double wall = static_cast<double>(now_us() - window_start) / 1e6;
    double sys1 = 0;
    res.cpu = (process_cpu_s(echo.pid, &sys1) - cpu0) / wall;
    res.sys = (sys1 - sys0) / wall;
    res.in_per_s = static_cast<double>(sent - sent0) / wall;
    res.out_per_s = static_cast<double>(received - received0) / wall;
    stop_server(echo);
    // Its syscalls per datagram (udp_echo's last line on stderr, written as it exits).
    std::ifstream f(log);
    for (std::string line; std::getline(f, line);) {
        unsigned long long d_in = 0, d_out = 0, receives = 0, sends = 0;
        if (std::sscanf(line.c_str(), "udp_echo: %llu datagrams in, %llu echoed, %llu receive calls, %llu send calls", &d_in, &d_out,
                        &receives, &sends) == 4 && d_in > 0) {
            res.receive_calls = static_cast<double>(receives) / static_cast<double>(d_in);
            res.send_calls = static_cast<double>(sends) / static_cast<double>(d_in);
        }
    }
    for (int fd : fds) close(fd);
    close(ep);
    return res;
}

}  // namespace lockroll::bench
