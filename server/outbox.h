// Outbox: the datagrams the relay's rooms queue during one pass, for the process to send.
// The per-datagram path of a busy server must not allocate: each entry keeps its byte buffer's
// capacity from one pass to the next (clear() empties the queue, not the buffers), so encoding
// a message into add()'s buffer reuses memory once the server has warmed up.
// Not thread-safe.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::server {

using ConnectionId = std::uint32_t;

struct Outgoing {
    ConnectionId to = 0;
    std::vector<std::uint8_t> bytes;
    bool reliable = false;  // welcome, notices, forwards: the transport's reliable channel
};

class Outbox {
public:
    // A new entry to `to`, with empty bytes (to append the encoded message to).
    Outgoing& add(ConnectionId to, bool reliable) {
        if (size_ == items_.size()) items_.emplace_back();
        Outgoing& o = items_[size_++];
        o.to = to;
        o.reliable = reliable;
        o.bytes.clear();
        return o;
    }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    std::span<Outgoing> items() { return {items_.data(), size_}; }
    // Empties the queue; the entries' buffers stay allocated for the next pass.
    void clear() { size_ = 0; }

private:
    std::vector<Outgoing> items_;
    std::size_t size_ = 0;
};

}  // namespace lockroll::server
