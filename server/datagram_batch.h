// DatagramBatch: one UDP socket's datagrams moved with one recvmmsg / sendmmsg per batch instead
// of one recvmsg / sendmsg each (the relay server's socket under ENet, whose API has no batching:
// server/enet_socket_batching.cpp feeds ENet from it; docs/relay.md, docs/performance.md).
//  - receive(): the next datagram; when none is buffered, one recvmmsg (non-blocking) reads up to
//    receive_slots of them. A datagram longer than a slot (max_bytes, ENet's largest MTU) is
//    dropped and counted, as a truncated read would be: a datagram is a claim, never an error.
//  - send(): copies the datagram into the next send slot (the caller's buffers are free at once);
//    a full queue is flushed first. flush() hands the queue to the kernel with sendmmsg; a
//    datagram the kernel refuses (buffer full, unreachable) is dropped and counted, as ENet's own
//    send drops one on EWOULDBLOCK: UDP promises nothing more.
// Memory is fixed at construction ((receive_slots + send_slots) * max_bytes); nothing grows with
// what arrives. IPv4 only (what ENet 1.3 speaks). Not thread-safe; reads no clock.
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::server {

struct DatagramBatchCounters {
    std::uint64_t receive_calls = 0;  // recvmmsg syscalls, empty ones included
    std::uint64_t send_calls = 0;     // sendmmsg syscalls
    std::uint64_t datagrams_in = 0, datagrams_out = 0;
    std::uint64_t dropped_oversized = 0, dropped_send = 0;
};

class DatagramBatch {
public:
    static constexpr std::size_t kMaxBytes = 4096;  // ENET_PROTOCOL_MAXIMUM_MTU
    // fd: a bound UDP socket (owned by the caller, left open). Throws std::invalid_argument on
    // zero slots.
    explicit DatagramBatch(int fd, std::size_t receive_slots = 64, std::size_t send_slots = 256);
    ~DatagramBatch();
    DatagramBatch(const DatagramBatch&) = delete;
    DatagramBatch& operator=(const DatagramBatch&) = delete;

    int fd() const { return fd_; }
    // Copies the next datagram into bufs (scattered in order, the rest cut off as recvmsg does)
    // and its sender into from. Returns its length, 0 when none waits, -1 on a socket error.
    int receive(sockaddr_in& from, const iovec* bufs, std::size_t count);
    // True when receive() has a datagram without a syscall.
    bool has_buffered() const { return next_received_ < received_; }
    // Queues bufs (gathered) for to. Returns the datagram's length, or -1 when it is longer than
    // kMaxBytes (nothing queued).
    int send(const sockaddr_in& to, const iovec* bufs, std::size_t count);
    std::size_t queued() const { return queued_; }
    // The bytes of the datagram send() queued last (empty when none is queued), to amend in place.
    std::span<std::uint8_t> last_queued() {
        if (queued_ == 0) return {};
        Slot& s = send_slots_[queued_ - 1];
        return {static_cast<std::uint8_t*>(s.iov.iov_base), s.iov.iov_len};
    }
    // Sends everything queued (one sendmmsg per run of accepted datagrams; a refused one is
    // dropped and the rest sent).
    void flush();
    const DatagramBatchCounters& counters() const { return counters_; }

private:
    struct Slot {
        sockaddr_in address{};
        iovec iov{};
    };
    int fill();  // one recvmmsg; -1 on a socket error, 0 otherwise (nothing waiting included)

    int fd_;
    std::vector<std::uint8_t> receive_bytes_, send_bytes_;
    std::vector<Slot> receive_slots_, send_slots_;
    std::vector<mmsghdr> receive_headers_, send_headers_;
    std::size_t received_ = 0, next_received_ = 0, queued_ = 0;
    DatagramBatchCounters counters_;
};

}  // namespace lockroll::server
