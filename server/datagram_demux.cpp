#include "server/datagram_demux.h"

#include <enet/enet.h>

#include <cstddef>
#include <cstring>
#include <stdexcept>

#include "transport/enet_datagram.h"

namespace lockroll::server {

namespace {
// ENet 1.3's datagram (enet/protocol.h, protocol.c): a 16-bit peer id whose top bits are flags
// and the session, the sent time when flagged, then the commands, each a fixed struct by its
// command byte, the send commands followed by their data.
constexpr std::uint16_t kPeerIdMask = ENET_PROTOCOL_MAXIMUM_PEER_ID;  // 0xFFF: not assigned yet
constexpr std::uint16_t kFlagCompressed = ENET_PROTOCOL_HEADER_FLAG_COMPRESSED;
constexpr std::uint16_t kFlagSentTime = ENET_PROTOCOL_HEADER_FLAG_SENT_TIME;

std::uint16_t read16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }
void write16(std::uint8_t* p, std::uint16_t v) {
    p[0] = static_cast<std::uint8_t>(v >> 8);
    p[1] = static_cast<std::uint8_t>(v);
}

// The size of command c's fixed part (ENet's commandSizes), 0 for none.
std::size_t command_size(std::uint8_t c) {
    switch (c & ENET_PROTOCOL_COMMAND_MASK) {
        case ENET_PROTOCOL_COMMAND_ACKNOWLEDGE: return sizeof(ENetProtocolAcknowledge);
        case ENET_PROTOCOL_COMMAND_CONNECT: return sizeof(ENetProtocolConnect);
        case ENET_PROTOCOL_COMMAND_VERIFY_CONNECT: return sizeof(ENetProtocolVerifyConnect);
        case ENET_PROTOCOL_COMMAND_DISCONNECT: return sizeof(ENetProtocolDisconnect);
        case ENET_PROTOCOL_COMMAND_PING: return sizeof(ENetProtocolPing);
        case ENET_PROTOCOL_COMMAND_SEND_RELIABLE: return sizeof(ENetProtocolSendReliable);
        case ENET_PROTOCOL_COMMAND_SEND_UNRELIABLE: return sizeof(ENetProtocolSendUnreliable);
        case ENET_PROTOCOL_COMMAND_SEND_FRAGMENT: return sizeof(ENetProtocolSendFragment);
        case ENET_PROTOCOL_COMMAND_SEND_UNSEQUENCED: return sizeof(ENetProtocolSendUnsequenced);
        case ENET_PROTOCOL_COMMAND_BANDWIDTH_LIMIT: return sizeof(ENetProtocolBandwidthLimit);
        case ENET_PROTOCOL_COMMAND_THROTTLE_CONFIGURE: return sizeof(ENetProtocolThrottleConfigure);
        case ENET_PROTOCOL_COMMAND_SEND_UNRELIABLE_FRAGMENT: return sizeof(ENetProtocolSendFragment);
        default: return 0;
    }
}

std::size_t header_size(std::uint16_t peer) { return (peer & kFlagSentTime) != 0 ? sizeof(ENetProtocolHeader) : sizeof(std::uint16_t); }
}  // namespace

DatagramDemux::DatagramDemux(const DatagramDemuxConfig& config) : config_(config), load_(config.hosts, 0) {
    if (config.hosts == 0 || config.capacity_per_host == 0 || config.max_per_ip == 0)
        throw std::invalid_argument("DatagramDemux: hosts, capacity and per-IP limit must be >= 1");
    const std::size_t all = config.connections > 0 ? config.connections : config.hosts * config.capacity_per_host;
    if (all > (config.hosts - 1) * config.capacity_per_host + config.capacity_per_host || all <= (config.hosts - 1) * config.capacity_per_host)
        throw std::invalid_argument("DatagramDemux: connections must fill the last host by 1..capacity");
    if (all >= kPeerIdMask) throw std::invalid_argument("DatagramDemux: at most 4,094 connections (ENet's peer ids)");
    last_capacity_ = all - (config.hosts - 1) * config.capacity_per_host;
}

bool DatagramDemux::is_connect(std::span<const std::uint8_t> d, std::uint32_t& connect_id, std::uint16_t& client_peer) {
    if (d.size() < 2) return false;
    const std::uint16_t peer = read16(d.data());
    if ((peer & kPeerIdMask) != kPeerIdMask || (peer & kFlagCompressed) != 0) return false;
    const std::size_t at = header_size(peer);
    if (d.size() < at + sizeof(ENetProtocolConnect) || (d[at] & ENET_PROTOCOL_COMMAND_MASK) != ENET_PROTOCOL_COMMAND_CONNECT) return false;
    std::memcpy(&connect_id, d.data() + at + offsetof(ENetProtocolConnect, connectID), sizeof connect_id);
    client_peer = read16(d.data() + at + offsetof(ENetProtocolConnect, outgoingPeerID));
    return true;
}

int DatagramDemux::route(std::uint32_t ip, std::uint16_t port, std::span<std::uint8_t> d, std::uint64_t now_us) {
    if (d.size() < 2) {
        ++counters_.dropped_unknown;
        return kDrop;
    }
    const std::uint16_t peer = read16(d.data());
    const std::size_t id = peer & kPeerIdMask;
    if (id != kPeerIdMask) {
        // A server peer's id: its host, and the host's own index in the header.
        const std::size_t host = id / config_.capacity_per_host;
        if (host >= load_.size()) {
            ++counters_.dropped_unknown;
            return kDrop;
        }
        write16(d.data(), static_cast<std::uint16_t>((peer & ~kPeerIdMask) | (id - host * config_.capacity_per_host)));
        ++counters_.peers;
        return static_cast<int>(host);
    }
    std::uint32_t connect_id = 0;
    std::uint16_t client_peer = 0;
    if (!is_connect(d, connect_id, client_peer)) {
        ++counters_.dropped_unknown;
        return kDrop;
    }
    if (!pending_.empty() && pending_.front().first <= now_us) expire(now_us);
    const Key k = key(ip, port, connect_id);
    if (const auto it = handshakes_.find(k); it != handshakes_.end()) {
        ++counters_.connect_repeats;
        return static_cast<int>(it->second.host);
    }
    // The client slot's previous handshake, if still pending, is given up (its count freed first,
    // so that a client cycling connects from one slot holds one handshake, not max_per_ip).
    if (const auto s = slots_.find(slot(k, client_peer)); s != slots_.end()) {
        const Key old = {k.address, s->second};
        slots_.erase(s);
        if (const auto it = handshakes_.find(old); it != handshakes_.end() && it->second.until != 0) {
            abandoned_.push_back({it->second.host, ip, port, old.connect_id});
            const std::size_t host = it->second.host;
            handshakes_.erase(it);  // its pending_ entry finds nothing when it expires
            release(host, ip);
            ++counters_.abandoned;
        }
    }
    const auto ip_count = per_ip_.find(ip);
    if (ip_count != per_ip_.end() && ip_count->second >= config_.max_per_ip) {
        ++counters_.dropped_limit;
        return kDrop;
    }
    std::size_t best = load_.size();
    for (std::size_t h = 0; h < load_.size(); ++h)
        if (load_[h] < capacity(h) && (best == load_.size() || load_[h] < load_[best])) best = h;
    if (best == load_.size()) {
        ++counters_.dropped_full;
        return kDrop;
    }
    ++per_ip_[ip];
    ++load_[best];
    const std::uint64_t until = now_us + config_.pending_us;
    handshakes_.emplace(k, Handshake{static_cast<std::uint32_t>(best), client_peer, until});
    pending_.emplace_back(until, k);
    slots_[slot(k, client_peer)] = connect_id;
    ++counters_.connects;
    return static_cast<int>(best);
}

void DatagramDemux::outgoing(std::size_t host, std::span<std::uint8_t> d) const {
    if (host == 0 || d.size() < 2) return;  // host 0's indexes are the server's ids
    const std::uint16_t peer = read16(d.data());
    // VERIFY_CONNECT is reliable: a datagram without a sent time carries no reliable command.
    if ((peer & kFlagSentTime) == 0) return;
    std::size_t at = header_size(peer);
    while (at < d.size()) {
        std::uint8_t* c = d.data() + at;
        const std::size_t size = command_size(c[0]);
        if (size == 0 || at + size > d.size()) return;  // not ENet's (or cut short): left as it is
        if ((c[0] & ENET_PROTOCOL_COMMAND_MASK) == ENET_PROTOCOL_COMMAND_VERIFY_CONNECT) {
            std::uint8_t* field = c + offsetof(ENetProtocolVerifyConnect, outgoingPeerID);
            write16(field, static_cast<std::uint16_t>(host * config_.capacity_per_host + read16(field)));
        }
        at += size + transport::enet_command_payload(c);
    }
}

void DatagramDemux::connected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) {
    if (host >= load_.size()) return;
    const Key k = key(ip, port, connect_id);
    auto [it, fresh] = handshakes_.try_emplace(k, Handshake{static_cast<std::uint32_t>(host), 0, 0});
    if (!fresh) {
        if (it->second.host != host || it->second.until == 0) return;  // another host's, or counted
        forget_slot(k, it->second);
        it->second.until = 0;  // the handshake is this connection now: its load and IP count stay
        ++connections_;
        return;
    }
    ++connections_;  // its handshake expired first (or never passed through route())
    ++load_[host];
    ++per_ip_[ip];
}

void DatagramDemux::disconnected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) {
    const auto it = handshakes_.find(key(ip, port, connect_id));
    if (it == handshakes_.end() || it->second.host != host || it->second.until != 0) return;
    handshakes_.erase(it);
    --connections_;
    release(host, ip);
}

bool DatagramDemux::next_abandoned(AbandonedHandshake& out) {
    if (abandoned_.empty()) return false;
    out = abandoned_.front();
    abandoned_.pop_front();
    return true;
}

void DatagramDemux::forget_slot(const Key& k, const Handshake& h) {
    if (const auto s = slots_.find(slot(k, h.client_peer)); s != slots_.end() && s->second == k.connect_id) slots_.erase(s);
}

void DatagramDemux::release(std::size_t host, std::uint32_t ip) {
    --load_[host];
    if (const auto p = per_ip_.find(ip); p != per_ip_.end() && --p->second == 0) per_ip_.erase(p);
}

void DatagramDemux::expire(std::uint64_t now_us) {
    while (!pending_.empty() && pending_.front().first <= now_us) {
        const auto [until, k] = pending_.front();
        pending_.pop_front();
        const auto it = handshakes_.find(k);
        if (it == handshakes_.end() || it->second.until != until) continue;  // connected
        const std::size_t host = it->second.host;
        forget_slot(k, it->second);
        handshakes_.erase(it);
        release(host, static_cast<std::uint32_t>(k.address >> 16));
    }
}

}  // namespace lockroll::server
