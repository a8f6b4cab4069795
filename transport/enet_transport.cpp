#include "transport/enet_transport.h"

#include <enet/enet.h>

#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

namespace lockroll::transport {

namespace {

constexpr enet_uint8 kInputChannel = 0;
// Upper bound on ENet events handled per poll, so one call stays bounded under a flood.
constexpr int kMaxEventsPerPoll = 4096;

// enet_initialize once per process, enet_deinitialize at exit.
void ensure_enet_initialized() {
    static std::once_flag once;
    static bool ok = false;
    std::call_once(once, [] {
        ok = enet_initialize() == 0;
        if (ok) std::atexit(enet_deinitialize);
    });
    if (!ok) throw std::runtime_error("ENet: enet_initialize failed");
}

void configure_peer(ENetPeer* peer) {
    // Deceleration 0: ENet never lowers the packet throttle, so it never discards our
    // unreliable input packets on its own; loss handling is the session's (redundant resends).
    enet_peer_throttle_configure(peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
}

}  // namespace

EnetTransport::EnetTransport(const EnetConfig& config) : local_id_(config.local_id) {
    ensure_enet_initialized();
    const std::string where = config.bind_host + ":" + std::to_string(config.port);
    ENetAddress address{};
    if (enet_address_set_host(&address, config.bind_host.c_str()) != 0)
        throw std::runtime_error("ENet: cannot resolve bind address " + where);
    address.port = config.port;
    host_ = enet_host_create(&address, config.max_peers, 1, 0, 0);
    if (host_ == nullptr) throw std::runtime_error("ENet: cannot create a host bound to " + where);
    ENetAddress bound{};
    port_ = enet_socket_get_address(host_->socket, &bound) == 0 ? bound.port : config.port;
}

EnetTransport::~EnetTransport() {
    for (auto& [id, conn] : by_id_) enet_peer_disconnect_now(conn.peer, 0);
    enet_host_flush(host_);
    enet_host_destroy(host_);
}

bool EnetTransport::connect(PeerId remote, const std::string& host, std::uint16_t port, std::string* error) {
    const auto fail = [&](std::string why) {
        if (error) *error = std::move(why);
        return false;
    };
    if (remote == local_id_) return fail("peer id " + std::to_string(remote) + " is the local id");
    if (by_id_.contains(remote)) return fail("peer id " + std::to_string(remote) + " is already connected or connecting");
    ENetAddress address{};
    if (enet_address_set_host(&address, host.c_str()) != 0) return fail("cannot resolve host '" + host + "'");
    address.port = port;
    ENetPeer* peer = enet_host_connect(host_, &address, 1, local_id_);
    if (peer == nullptr) return fail("no free ENet connection slot");
    by_id_[remote] = Connection{peer, false};
    by_peer_[peer] = remote;
    return true;
}

std::uint64_t EnetTransport::wire_bytes_sent() const { return host_->totalSentData; }
std::uint64_t EnetTransport::wire_bytes_received() const { return host_->totalReceivedData; }

bool EnetTransport::is_connected(PeerId remote) const {
    const auto it = by_id_.find(remote);
    return it != by_id_.end() && it->second.established;
}

std::vector<PeerId> EnetTransport::connected_peers() const {
    std::vector<PeerId> ids;
    for (const auto& [id, conn] : by_id_)
        if (conn.established) ids.push_back(id);
    return ids;
}

void EnetTransport::forget(ENetPeer* peer) {
    const auto it = by_peer_.find(peer);
    if (it == by_peer_.end()) return;
    by_id_.erase(it->second);
    by_peer_.erase(it);
}

void EnetTransport::handle(const ENetEvent& event, Micros now) {
    switch (event.type) {
        case ENET_EVENT_TYPE_CONNECT: {
            if (const auto it = by_peer_.find(event.peer); it != by_peer_.end()) {
                by_id_[it->second].established = true;  // our outgoing connect completed
                configure_peer(event.peer);
                return;
            }
            const PeerId remote = event.data;
            if (remote == local_id_ || by_id_.contains(remote)) {
                ++counters_.rejected;
                enet_peer_disconnect_now(event.peer, 0);
                return;
            }
            by_id_[remote] = Connection{event.peer, true};
            by_peer_[event.peer] = remote;
            configure_peer(event.peer);
            return;
        }
        case ENET_EVENT_TYPE_RECEIVE: {
            const auto it = by_peer_.find(event.peer);
            const bool known = it != by_peer_.end() && by_id_[it->second].established;
            if (!known || event.channelID != kInputChannel || event.packet->dataLength > kMaxDatagramBytes) {
                ++counters_.rejected;
            } else {
                Datagram d;
                d.from = it->second;
                d.time_us = now;
                d.bytes.assign(event.packet->data, event.packet->data + event.packet->dataLength);
                inbox_.push_back(std::move(d));
            }
            enet_packet_destroy(event.packet);
            return;
        }
        case ENET_EVENT_TYPE_DISCONNECT:
            forget(event.peer);
            return;
        case ENET_EVENT_TYPE_NONE:
            return;
    }
}

void EnetTransport::poll(Micros now) {
    ENetEvent event;
    for (int i = 0; i < kMaxEventsPerPoll; ++i) {
        const int r = enet_host_service(host_, &event, 0);
        if (r < 0) {
            ++service_errors_;
            return;
        }
        if (r == 0) return;
        handle(event, now);
    }
}

bool EnetTransport::send(PeerId to, std::span<const std::uint8_t> bytes, Micros /*now*/) {
    const auto it = by_id_.find(to);
    if (it == by_id_.end() || !it->second.established || bytes.size() > kMaxDatagramBytes) {
        ++counters_.rejected;
        return false;
    }
    ++counters_.datagrams_sent;
    counters_.bytes_sent += bytes.size();
    ENetPacket* packet = enet_packet_create(bytes.data(), bytes.size(), ENET_PACKET_FLAG_UNSEQUENCED);
    if (packet == nullptr) {
        ++counters_.dropped;
        return true;
    }
    if (enet_peer_send(it->second.peer, kInputChannel, packet) != 0) {
        // Not queued: ENet did not take ownership.
        if (packet->referenceCount == 0) enet_packet_destroy(packet);
        ++counters_.dropped;
        return true;
    }
    enet_host_flush(host_);
    return true;
}

bool EnetTransport::receive(Datagram& out, Micros now) {
    if (inbox_.empty()) poll(now);
    if (inbox_.empty()) return false;
    Datagram& front = inbox_.front();
    out.from = front.from;
    out.time_us = front.time_us;
    out.bytes.swap(front.bytes);
    inbox_.pop_front();
    ++counters_.datagrams_received;
    counters_.bytes_received += out.bytes.size();
    return true;
}

}  // namespace lockroll::transport
