#include "net/udp_proxy.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include "net/clock.h"

namespace lockroll::net {

namespace {

constexpr std::size_t kBufferBytes = 65'536;     // any UDP datagram
constexpr int kReadsPerSocketPerStep = 256;       // one busy socket cannot starve the others
constexpr std::uint64_t kStopCheckUs = 50'000;
// How long a stopped proxy goes on delivering what it holds (latency + jitter of every test and
// harness run is well under it; a queue of datagrams held longer is dropped at exit).
constexpr std::uint64_t kDrainUs = 1'000'000;
constexpr std::uint64_t kIdleCheckUs = 1'000'000;

int udp_socket(int family) {
    return ::socket(family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

UdpProxy::UdpProxy(const UdpProxyConfig& config) : config_(config), buffer_(kBufferBytes) {
    if (const std::string e = transport::validate(config.link); !e.empty())
        throw std::invalid_argument("proxy: link: " + e);
    for (const auto& [address, slot] : config.client_slots) client_slots_[address.key()] = slot;
    const std::string where = config.listen.to_string();
    listen_fd_ = udp_socket(config.listen.family());
    if (listen_fd_ < 0) throw std::runtime_error("proxy: cannot create a socket for " + where + ": " + errno_text());
    if (::bind(listen_fd_, config.listen.sockaddr_ptr(), config.listen.length) != 0) {
        const std::string why = errno_text();
        ::close(listen_fd_);
        throw std::runtime_error("proxy: cannot bind " + where + ": " + why);
    }
    sockaddr_storage bound{};
    socklen_t len = sizeof bound;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &len);
    port_ = udp_address_from(bound, len).port();
}

UdpProxy::~UdpProxy() {
    for (auto& [id, c] : clients_) ::close(c.upstream_fd);
    ::close(listen_fd_);
}

std::optional<std::uint32_t> UdpProxy::find_or_add_client(const UdpAddress& from, std::uint64_t now) {
    const std::string key = from.key();
    if (const auto it = client_ids_.find(key); it != client_ids_.end()) return it->second;
    if (clients_.size() >= config_.max_clients) return std::nullopt;
    const int fd = udp_socket(config_.upstream.family());
    if (fd < 0) {
        ++counters_.socket_errors;
        return std::nullopt;
    }
    // connect(): the kernel then delivers only the server's datagrams to this socket.
    if (::connect(fd, config_.upstream.sockaddr_ptr(), config_.upstream.length) != 0) {
        ::close(fd);
        ++counters_.socket_errors;
        return std::nullopt;
    }
    const std::uint32_t id = next_client_++;
    Client c;
    c.address = from;
    c.upstream_fd = fd;
    c.up = transport::LinkModel(transport::CounterRng::derive(config_.seed, id + 1, 0), config_.link);
    c.down = transport::LinkModel(transport::CounterRng::derive(config_.seed, 0, id + 1), config_.link);
    if (const auto slot = client_slots_.find(key); slot != client_slots_.end()) c.slot = slot->second;
    c.last_active_us = now;
    client_ids_[key] = id;
    ++counters_.clients;
    clients_.emplace(id, std::move(c));
    return id;
}

bool UdpProxy::is_cut(const Client& client, std::uint64_t now) const {
    if (config_.partitions.empty() || !client.slot || !config_.upstream_slot || now < config_.partition_epoch_us)
        return false;
    return config_.partitions.is_cut(*client.slot, *config_.upstream_slot, now - config_.partition_epoch_us);
}

void UdpProxy::impair(std::uint32_t id, bool to_server, const std::uint8_t* data, std::size_t size,
                      std::uint64_t now) {
    Client& c = clients_.at(id);
    c.last_active_us = now;
    transport::LinkModel& link = to_server ? c.up : c.down;
    if (is_cut(c, now)) {
        link.cut();
        ++counters_.partitioned;
        return;
    }
    const transport::PacketFate fate = link.transmit(size, now);
    if (!fate.delivered) {
        ++counters_.dropped;
        return;
    }
    if (fate.reordered) ++counters_.reordered;
    const auto enqueue = [&](std::uint64_t due) {
        if (queue_.size() >= config_.max_queued || queued_bytes_ + size > config_.max_queued_bytes) {
            ++counters_.queue_full;
            return;
        }
        queue_.push(Pending{due, next_sequence_++, id, to_server, std::vector<std::uint8_t>(data, data + size)});
        queued_bytes_ += size;
    };
    enqueue(fate.arrive_us);
    if (fate.duplicated) {
        ++counters_.duplicated;
        enqueue(fate.copy_us);
    }
}

// Each datagram is timed by a clock read after its recvfrom returns, never by one read before
// the batch: if the process is preempted between a clock read and the recv, a datagram sent in
// that gap would otherwise be scheduled from a time before it was sent, and delivered early.
// Read after receipt, the error is only ever lateness.
void UdpProxy::read_clients() {
    for (int i = 0; i < kReadsPerSocketPerStep; ++i) {
        sockaddr_storage from{};
        socklen_t len = sizeof from;
        const ssize_t n = ::recvfrom(listen_fd_, buffer_.data(), buffer_.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
        if (n < 0) {
            if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) ++counters_.socket_errors;
            return;
        }
        const std::uint64_t now = now_us();
        ++counters_.received;
        const auto id = find_or_add_client(udp_address_from(from, len), now);
        if (!id) {
            ++counters_.refused_clients;
            continue;
        }
        impair(*id, true, buffer_.data(), static_cast<std::size_t>(n), now);
    }
}

void UdpProxy::read_server(std::uint32_t id, Client& client) {
    for (int i = 0; i < kReadsPerSocketPerStep; ++i) {
        const ssize_t n = ::recv(client.upstream_fd, buffer_.data(), buffer_.size(), 0);
        if (n < 0) {
            // ECONNREFUSED: an ICMP port unreachable from a server that is not (yet) listening.
            if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) ++counters_.socket_errors;
            return;
        }
        ++counters_.received;
        impair(id, false, buffer_.data(), static_cast<std::size_t>(n), now_us());
    }
}

void UdpProxy::deliver_due(std::uint64_t now) {
    while (!queue_.empty() && queue_.top().due_us <= now) {
        const Pending& p = queue_.top();
        queued_bytes_ -= p.bytes.size();
        if (const auto it = clients_.find(p.client); it != clients_.end()) {
            const Client& c = it->second;
            const ssize_t n = p.to_server
                                  ? ::send(c.upstream_fd, p.bytes.data(), p.bytes.size(), 0)
                                  : ::sendto(listen_fd_, p.bytes.data(), p.bytes.size(), 0, c.address.sockaddr_ptr(),
                                             c.address.length);
            if (n < 0)
                ++counters_.socket_errors;
            else
                ++counters_.forwarded;
        }
        queue_.pop();
    }
}

void UdpProxy::forget_idle(std::uint64_t now) {
    if (now < next_idle_check_us_) return;
    next_idle_check_us_ = now + kIdleCheckUs;
    for (auto it = clients_.begin(); it != clients_.end();) {
        if (now - it->second.last_active_us >= config_.client_idle_us) {
            ::close(it->second.upstream_fd);
            client_ids_.erase(it->second.address.key());
            it = clients_.erase(it);  // its queued datagrams are dropped when due
        } else {
            ++it;
        }
    }
}

void UdpProxy::step(std::uint64_t max_wait_us) {
    std::uint64_t now = now_us();
    deliver_due(now);
    forget_idle(now);

    std::uint64_t wait = max_wait_us;
    if (!queue_.empty()) wait = std::min(wait, queue_.top().due_us > now ? queue_.top().due_us - now : 0);
    std::vector<pollfd> fds;
    std::vector<std::uint32_t> ids;
    fds.push_back({listen_fd_, POLLIN, 0});
    for (const auto& [id, c] : clients_) {
        fds.push_back({c.upstream_fd, POLLIN, 0});
        ids.push_back(id);
    }
    const timespec timeout{static_cast<time_t>(wait / 1'000'000), static_cast<long>((wait % 1'000'000) * 1000)};
    const int ready = ::ppoll(fds.data(), fds.size(), &timeout, nullptr);
    if (ready <= 0) return;  // timeout, or EINTR from a signal: the caller checks its stop flag
    if (fds[0].revents != 0) read_clients();
    for (std::size_t i = 1; i < fds.size(); ++i) {
        if (fds[i].revents == 0) continue;
        const auto it = clients_.find(ids[i - 1]);
        if (it != clients_.end()) read_server(it->first, it->second);
    }
}

void UdpProxy::run(const std::atomic<bool>& stop, std::uint64_t deadline_us) {
    while (!stop.load()) {
        std::uint64_t wait = kStopCheckUs;
        if (deadline_us != 0) {
            const std::uint64_t now = now_us();
            if (now >= deadline_us) return;
            wait = std::min(wait, deadline_us - now);
        }
        step(wait);
    }
    // Stopped: what is already in flight still arrives, for at most kDrainUs. A wire does not
    // lose a datagram because the run ends: the last one a finished process sent (its ENet
    // goodbye, held here for its latency) was lost when `lockroll live` stopped the proxies
    // just after the processes ended, and the relay server then logged that finished client as
    // kicked for silence.
    const std::uint64_t until = now_us() + kDrainUs;
    for (std::uint64_t now = now_us(); now < until; now = now_us()) {
        deliver_due(now);
        if (queue_.empty()) return;
        const std::uint64_t next = std::min(queue_.top().due_us, until);
        if (next > now) std::this_thread::sleep_for(std::chrono::microseconds(next - now));
    }
}

}  // namespace lockroll::net
