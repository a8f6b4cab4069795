#include "transport/enet_server.h"

#include <enet/enet.h>

#include "transport/enet_library.h"

#include <cstdlib>
#include <mutex>
#include <stdexcept>

namespace lockroll::transport {

namespace {
constexpr enet_uint8 kInputChannel = 0;
constexpr enet_uint8 kReliableChannel = 1;
constexpr int kMaxEventsPerPoll = 8192;
constexpr int kMaxErrorsPerPoll = 1024;
// Datagrams ENet reads from the socket per enet_host_service call (protocol.c, 1.3.x).
constexpr int kEnetReceiveBatch = 256;


std::uint32_t id_of(const ENetPeer* p) { return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(p->data)); }

std::string address_text(const ENetAddress& a) {
    char host[64] = {};
    if (enet_address_get_host_ip(&a, host, sizeof host) != 0) return "?";
    return std::string(host) + ":" + std::to_string(a.port);
}
}  // namespace

EnetServer::EnetServer(const EnetServerConfig& config) : config_(config) {
    if (config.max_connections < 1 || config.max_connections > ENET_PROTOCOL_MAXIMUM_PEER_ID)
        throw std::invalid_argument("EnetServer: max_connections must be 1.." + std::to_string(ENET_PROTOCOL_MAXIMUM_PEER_ID));
    if (config.max_connections_per_address < 1) throw std::invalid_argument("EnetServer: max_connections_per_address must be >= 1");
    if (config.max_packet_bytes < kMaxDatagramBytes)
        throw std::invalid_argument("EnetServer: max_packet_bytes must be >= " + std::to_string(kMaxDatagramBytes));
    ensure_enet_initialized();
    const std::string where = config.bind_host + ":" + std::to_string(config.port);
    ENetAddress address{};
    if (enet_address_set_host(&address, config.bind_host.c_str()) != 0)
        throw std::runtime_error("ENet: cannot resolve listen address " + where);
    address.port = config.port;
    host_ = enet_host_create(&address, config.max_connections, 2, 0, 0);
    if (host_ == nullptr) throw std::runtime_error("ENet: cannot listen on " + where + " (in use, or not a local address)");
    host_->duplicatePeers = config.max_connections_per_address;
    host_->maximumPacketSize = config.max_packet_bytes;
    host_->maximumWaitingData = config.max_waiting_bytes;
    enet_socket_set_option(host_->socket, ENET_SOCKOPT_RCVBUF, config.socket_receive_bytes);
    enet_socket_set_option(host_->socket, ENET_SOCKOPT_SNDBUF, config.socket_send_bytes);
    ENetAddress bound{};
    port_ = enet_socket_get_address(host_->socket, &bound) == 0 ? bound.port : config.port;
}

EnetServer::~EnetServer() {
    for (auto& r : inbox_) enet_packet_destroy(r.packet);
    for (auto& [id, peer] : by_id_) enet_peer_disconnect_now(peer, 0);
    enet_host_flush(host_);
    enet_host_destroy(host_);
}

void EnetServer::release_taken() {
    for (std::size_t i = 0; i < inbox_next_; ++i) enet_packet_destroy(inbox_[i].packet);
    inbox_.erase(inbox_.begin(), inbox_.begin() + static_cast<std::ptrdiff_t>(inbox_next_));
    inbox_next_ = 0;
}

void EnetServer::poll(Micros now, std::uint32_t wait_us) {
    release_taken();
    // enet_host_service sends what is queued before it reads, unless it has events left over
    // from the last poll to hand out first: then flush, or queued sends would wait.
    if (events_left_) enet_host_flush(host_);
    events_left_ = false;
    ENetEvent e;
    int errors = 0;
    enet_uint32 wait_ms = (wait_us + 999) / 1000;
    int handled = 0;
    while (handled < kMaxEventsPerPoll) {
        // Each enet_host_service call walks every peer slot of the host twice (acks, pings,
        // queued sends) around one read of at most kEnetReceiveBatch datagrams; with thousands
        // of slots those walks are most of the server's cost. So one call reads the socket and
        // enet_host_check_events (no walk) dispatches what it read; another call follows only
        // if that batch may have left datagrams in the socket.
        const int r = enet_host_service(host_, &e, wait_ms);
        wait_ms = 0;
        if (r < 0) {
            ++counters_.service_errors;
            if (++errors >= kMaxErrorsPerPoll) break;
            continue;
        }
        if (r == 0) break;
        int batch = 0;
        do {
            handle(e, now);
            ++handled;
            ++batch;
        } while (handled < kMaxEventsPerPoll && enet_host_check_events(host_, &e) > 0);
        if (batch < kEnetReceiveBatch) break;
    }
    events_left_ = handled >= kMaxEventsPerPoll;
}

void EnetServer::handle(const _ENetEvent& ev, Micros now) {
    ENetEvent e = ev;
    switch (e.type) {
        case ENET_EVENT_TYPE_CONNECT: {
            const std::uint32_t id = next_id_++;
            if (next_id_ == 0) next_id_ = 1;
            e.peer->data = reinterpret_cast<void*>(static_cast<std::uintptr_t>(id));
            enet_peer_timeout(e.peer, config_.timeout_limit, config_.timeout_min_ms, config_.timeout_max_ms);
            enet_peer_throttle_configure(e.peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
            by_id_[id] = e.peer;
            ++counters_.connections;
            events_.push_back({ServerConnectionEvent::Type::Connected, id, address_text(e.peer->address)});
            break;
        }
        case ENET_EVENT_TYPE_DISCONNECT: {
            const std::uint32_t id = id_of(e.peer);
            if (id != 0 && by_id_.erase(id)) {
                ++counters_.disconnects;
                events_.push_back({ServerConnectionEvent::Type::Disconnected, id, address_text(e.peer->address)});
            }
            e.peer->data = nullptr;
            break;
        }
        case ENET_EVENT_TYPE_RECEIVE: {
            const std::uint32_t id = id_of(e.peer);
            if (e.channelID > kReliableChannel) ++counters_.dropped_bad_channel;
            else if (e.packet->dataLength > kMaxDatagramBytes) ++counters_.dropped_oversized;
            else if (inbox_.size() - inbox_next_ >= config_.max_inbox) ++counters_.dropped_inbox_full;
            else if (id != 0) {
                inbox_.push_back({id, e.packet, now});  // destroyed once taken (release_taken)
                ++counters_.datagrams_in;
                break;
            }
            enet_packet_destroy(e.packet);
            break;
        }
        default: break;
    }
}

bool EnetServer::next_event(ServerConnectionEvent& out) {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

bool EnetServer::receive(ServerDatagram& out) {
    if (inbox_next_ == inbox_.size()) {
        release_taken();
        return false;
    }
    const Received& r = inbox_[inbox_next_++];
    out.connection = r.connection;
    out.bytes = {r.packet->data, r.packet->dataLength};
    out.time_us = r.time_us;
    return true;
}

bool EnetServer::send(std::uint32_t connection, std::span<const std::uint8_t> bytes, bool reliable) {
    const auto it = by_id_.find(connection);
    if (it == by_id_.end() || bytes.size() > kMaxDatagramBytes) return false;
    ENetPacket* p = enet_packet_create(bytes.data(), bytes.size(), reliable ? ENET_PACKET_FLAG_RELIABLE : ENET_PACKET_FLAG_UNSEQUENCED);
    if (p == nullptr || enet_peer_send(it->second, reliable ? kReliableChannel : kInputChannel, p) != 0) {
        if (p) enet_packet_destroy(p);
        ++counters_.send_failures;
        return false;
    }
    ++counters_.datagrams_out;
    return true;
}

void EnetServer::flush() { enet_host_flush(host_); }

void EnetServer::disconnect(std::uint32_t connection) {
    const auto it = by_id_.find(connection);
    if (it != by_id_.end()) enet_peer_disconnect_later(it->second, 0);
}

int EnetServer::socket_fd() const { return static_cast<int>(host_->socket); }
std::uint64_t EnetServer::wire_bytes_sent() const { return host_->totalSentData; }
std::uint64_t EnetServer::wire_bytes_received() const { return host_->totalReceivedData; }

}  // namespace lockroll::transport
