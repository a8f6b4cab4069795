#include "server/datagram_batch.h"

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace lockroll::server {

DatagramBatch::DatagramBatch(int fd, std::size_t receive_slots, std::size_t send_slots) : fd_(fd) {
    if (receive_slots == 0 || send_slots == 0) throw std::invalid_argument("DatagramBatch: slots must be >= 1");
    receive_bytes_.resize(receive_slots * kMaxBytes);
    send_bytes_.resize(send_slots * kMaxBytes);
    receive_slots_.resize(receive_slots);
    send_slots_.resize(send_slots);
    receive_headers_.resize(receive_slots);
    send_headers_.resize(send_slots);
    for (std::size_t i = 0; i < receive_slots; ++i) {
        receive_slots_[i].iov = {&receive_bytes_[i * kMaxBytes], kMaxBytes};
        msghdr& h = receive_headers_[i].msg_hdr;
        h = {};
        h.msg_name = &receive_slots_[i].address;
        h.msg_namelen = sizeof(sockaddr_in);
        h.msg_iov = &receive_slots_[i].iov;
        h.msg_iovlen = 1;
    }
    for (std::size_t i = 0; i < send_slots; ++i) send_slots_[i].iov = {&send_bytes_[i * kMaxBytes], 0};
}

DatagramBatch::~DatagramBatch() = default;

int DatagramBatch::fill() {
    // The kernel rewrites only msg_namelen, msg_flags and msg_len of the headers it filled: reset
    // those, the rest was set once (constructor).
    for (std::size_t i = 0; i < received_; ++i) receive_headers_[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
    ++counters_.receive_calls;
    const int n = recvmmsg(fd_, receive_headers_.data(), static_cast<unsigned>(receive_headers_.size()), MSG_DONTWAIT, nullptr);
    received_ = n > 0 ? static_cast<std::size_t>(n) : 0;
    next_received_ = 0;
    return n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR ? -1 : 0;
}

int DatagramBatch::receive(sockaddr_in& from, const iovec* bufs, std::size_t count) {
    for (;;) {
        if (next_received_ == received_) {
            const int error = fill();
            if (received_ == 0) return error;
        }
        const mmsghdr& m = receive_headers_[next_received_];
        const Slot& slot = receive_slots_[next_received_++];
        if ((m.msg_hdr.msg_flags & MSG_TRUNC) != 0) {
            ++counters_.dropped_oversized;
            continue;
        }
        ++counters_.datagrams_in;
        from = slot.address;
        const auto* src = static_cast<const std::uint8_t*>(slot.iov.iov_base);
        std::size_t left = m.msg_len, copied = 0;
        for (std::size_t b = 0; b < count && left > 0; ++b) {
            const std::size_t k = left < bufs[b].iov_len ? left : bufs[b].iov_len;
            std::memcpy(bufs[b].iov_base, src + copied, k);
            copied += k;
            left -= k;
        }
        return static_cast<int>(copied);
    }
}

int DatagramBatch::send(const sockaddr_in& to, const iovec* bufs, std::size_t count) {
    std::size_t total = 0;
    for (std::size_t b = 0; b < count; ++b) total += bufs[b].iov_len;
    if (total > kMaxBytes) return -1;
    if (queued_ == send_slots_.size()) flush();
    Slot& slot = send_slots_[queued_++];
    slot.address = to;
    auto* dst = static_cast<std::uint8_t*>(slot.iov.iov_base);
    std::size_t at = 0;
    for (std::size_t b = 0; b < count; ++b) {
        std::memcpy(dst + at, bufs[b].iov_base, bufs[b].iov_len);
        at += bufs[b].iov_len;
    }
    slot.iov.iov_len = total;
    return static_cast<int>(total);
}

void DatagramBatch::flush() {
    for (std::size_t i = 0; i < queued_; ++i) {
        msghdr& h = send_headers_[i].msg_hdr;
        h = {};
        h.msg_name = &send_slots_[i].address;
        h.msg_namelen = sizeof(sockaddr_in);
        h.msg_iov = &send_slots_[i].iov;
        h.msg_iovlen = 1;
    }
    std::size_t at = 0;
    while (at < queued_) {
        ++counters_.send_calls;
        const int n = sendmmsg(fd_, &send_headers_[at], static_cast<unsigned>(queued_ - at), MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR) continue;
            ++counters_.dropped_send;  // the first of the rest was refused: drop it, send the others
            ++at;
            continue;
        }
        counters_.datagrams_out += static_cast<std::uint64_t>(n);
        at += static_cast<std::size_t>(n);
    }
    queued_ = 0;
}

}  // namespace lockroll::server
