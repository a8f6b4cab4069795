#include "transport/enet_server.h"

#include <enet/enet.h>

#include "transport/enet_handshakes.h"
#include "transport/enet_library.h"

#include <cstdlib>
#include <cstring>
#include <limits>
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


// The server whose host is inside enet_host_service on this thread: ENet's intercept callback
// has no user pointer.
thread_local EnetServer* t_servicing = nullptr;

int ENET_CALLBACK intercept_callback(ENetHost* host, ENetEvent* /*event*/) {
    return t_servicing != nullptr ? t_servicing->intercept(host) : 0;
}

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
    const bool shared = config.fanout != nullptr && config.connections_per_host > 0 && config.connections_per_host < config.max_connections;
    const std::size_t per_host = shared ? config.connections_per_host : config.max_connections;
    const auto configure = [&](ENetHost* h) {
        h->duplicatePeers = config.max_connections_per_address;
        h->maximumPacketSize = config.max_packet_bytes;
        h->maximumWaitingData = config.max_waiting_bytes;
        h->intercept = intercept_callback;
    };
    ENetHost* first = enet_host_create(&address, per_host, 2, 0, 0);
    if (first == nullptr) throw std::runtime_error("ENet: cannot listen on " + where + " (in use, or not a local address)");
    configure(first);
    enet_socket_set_option(first->socket, ENET_SOCKOPT_RCVBUF, config.socket_receive_bytes);
    enet_socket_set_option(first->socket, ENET_SOCKOPT_SNDBUF, config.socket_send_bytes);
    hosts_.push_back(first);
    if (shared) {
        const std::size_t count = (config.max_connections + per_host - 1) / per_host;
        std::vector<int> ids = config.fanout->attach(static_cast<int>(first->socket), count, per_host, config.max_connections,
                                                     config.max_connections_per_address, fanout_why_);
        if (ids.size() == count) {
            for (std::size_t i = 1; i < count; ++i) {
                // An unbound host whose own socket is closed at once: it sends and reads through
                // the fanout, under the id it was given. The last holds what is left.
                const std::size_t peers = i + 1 < count ? per_host : config.max_connections - i * per_host;
                ENetHost* h = enet_host_create(nullptr, peers, 2, 0, 0);
                if (h == nullptr) {
                    for (auto* made : hosts_) enet_host_destroy(made);
                    throw std::runtime_error("ENet: cannot create host " + std::to_string(i) + " of " + std::to_string(count));
                }
                configure(h);
                enet_socket_destroy(h->socket);
                h->socket = static_cast<ENetSocket>(ids[i]);
                hosts_.push_back(h);
            }
            fanout_ = config.fanout;
            if (config.direct_unsequenced) fanout_->set_claim(&EnetServer::claim_thunk, this);
            fanout_->set_abandon(&EnetServer::abandon_thunk, this);
        } else {
            // One host for every connection, as without a fanout.
            if (fanout_why_.empty()) fanout_why_ = "the fanout gave no socket ids";
            enet_host_destroy(first);
            hosts_.clear();
            first = enet_host_create(&address, config.max_connections, 2, 0, 0);
            if (first == nullptr) throw std::runtime_error("ENet: cannot listen on " + where + " (in use, or not a local address)");
            configure(first);
            enet_socket_set_option(first->socket, ENET_SOCKOPT_RCVBUF, config.socket_receive_bytes);
            enet_socket_set_option(first->socket, ENET_SOCKOPT_SNDBUF, config.socket_send_bytes);
            hosts_.push_back(first);
        }
    }
    dirty_.assign(hosts_.size(), 0);
    serviced_at_.assign(hosts_.size(), 0);
    ENetAddress bound{};
    port_ = enet_socket_get_address(first->socket, &bound) == 0 ? bound.port : config.port;
}

EnetServer::~EnetServer() {
    if (fanout_) {
        fanout_->set_claim(nullptr, nullptr);
        fanout_->set_abandon(nullptr, nullptr);
    }
    for (auto& r : inbox_)
        if (r.packet) enet_packet_destroy(r.packet);
    for (auto& [id, c] : by_id_) enet_peer_disconnect_now(c.peer, 0);
    for (auto* h : hosts_) enet_host_flush(h);
    // The shared socket's host last: the others send through it until then.
    for (std::size_t i = hosts_.size(); i-- > 0;) enet_host_destroy(hosts_[i]);
}

void EnetServer::release_taken() {
    for (std::size_t i = 0; i < inbox_next_; ++i)
        if (inbox_[i].packet) enet_packet_destroy(inbox_[i].packet);
    inbox_.erase(inbox_.begin(), inbox_.begin() + static_cast<std::ptrdiff_t>(inbox_next_));
    inbox_next_ = 0;
}

void EnetServer::mark_dirty(std::size_t host) {
    if (dirty_[host]) return;
    dirty_[host] = 1;
    dirty_list_.push_back(host);
}

void EnetServer::service(std::size_t h, Micros now, std::uint32_t wait_ms, int& handled) {
    ENetHost* host = hosts_[h];
    ENetEvent e;
    int errors = 0;
    // One host: the socket's datagrams stay in the kernel (or the batch) if a poll stops at its
    // event cap. Several: what the fanout routed to this host is gone at the next receive, so
    // the host reads until its queue is empty.
    const int cap = fanout_ ? std::numeric_limits<int>::max() : kMaxEventsPerPoll;
    while (handled < cap) {
        // Each enet_host_service call walks every peer slot of the host twice (acks, pings,
        // queued sends) around one read of at most kEnetReceiveBatch datagrams; with thousands
        // of slots those walks are most of the server's cost. So one call reads the socket and
        // enet_host_check_events (no walk) dispatches what it read; another call follows only
        // if that batch may have left datagrams in the socket (or in the host's queue).
        t_servicing = this;
        const int r = enet_host_service(host, &e, wait_ms);
        t_servicing = nullptr;
        ++counters_.host_services;
        wait_ms = 0;
        if (r < 0) {
            ++counters_.service_errors;
            if (++errors >= kMaxErrorsPerPoll) break;
            continue;
        }
        if (r == 0) {
            if (fanout_ && fanout_->holds(h)) continue;
            break;
        }
        int batch = 0;
        do {
            handle(e, h, now);
            ++handled;
            ++batch;
        } while (handled < cap && enet_host_check_events(host, &e) > 0);
        if (batch < kEnetReceiveBatch && !(fanout_ && fanout_->holds(h))) break;
    }
    dirty_[h] = 0;
    serviced_at_[h] = now;
}

void EnetServer::poll(Micros now, std::uint32_t wait_us) {
    release_taken();
    int handled = 0;
    if (!fanout_) {
        // enet_host_service sends what is queued before it reads, unless it has events left over
        // from the last poll to hand out first: then flush, or queued sends would wait.
        if (events_left_) enet_host_flush(hosts_[0]);
        service(0, now, (wait_us + 999) / 1000, handled);
        events_left_ = handled >= kMaxEventsPerPoll;
        dirty_list_.clear();
        return;
    }
    // What the hosts queued since the last poll leaves first (one walk of each such host: a
    // service would walk it twice), and before the wait (the fanout's wait flushes its batch).
    flush();
    if (wait_us > 0) {
        enet_uint32 condition = ENET_SOCKET_WAIT_RECEIVE;
        enet_socket_wait(hosts_[0]->socket, &condition, (wait_us + 999) / 1000);
    }
    ready_.clear();
    poll_now_ = now;  // for claim(), which receive() calls
    fanout_->receive(now, ready_);
    for (std::size_t h : ready_) service(h, now, 0, handled);
    // Hosts without traffic still have timers (pings, resends, timeouts, a disconnect to finish).
    const Micros idle = Micros{config_.idle_service_ms} * 1000;
    if (now >= next_idle_scan_) {
        next_idle_scan_ = now + idle / 4;
        for (std::size_t h = 0; h < hosts_.size(); ++h)
            if (now - serviced_at_[h] >= idle) {
                ++counters_.idle_services;
                service(h, now, 0, handled);
            }
    }
}

void EnetServer::handle(const _ENetEvent& ev, std::size_t host, Micros now) {
    ENetEvent e = ev;
    switch (e.type) {
        case ENET_EVENT_TYPE_CONNECT: {
            const std::uint32_t id = next_id_++;
            if (next_id_ == 0) next_id_ = 1;
            e.peer->data = reinterpret_cast<void*>(static_cast<std::uintptr_t>(id));
            enet_peer_timeout(e.peer, config_.timeout_limit, config_.timeout_min_ms, config_.timeout_max_ms);
            enet_peer_throttle_configure(e.peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
            by_id_[id] = {e.peer, host, e.peer->connectID};
            ++counters_.connections;
            if (fanout_) fanout_->connected(host, e.peer->address.host, e.peer->address.port, e.peer->connectID);
            events_.push_back({ServerConnectionEvent::Type::Connected, id, address_text(e.peer->address)});
            break;
        }
        case ENET_EVENT_TYPE_DISCONNECT: {
            const std::uint32_t id = id_of(e.peer);
            const auto it = id != 0 ? by_id_.find(id) : by_id_.end();
            if (it != by_id_.end()) {
                const std::uint32_t connect_id = it->second.connect_id;
                by_id_.erase(it);
                ++counters_.disconnects;
                if (fanout_) fanout_->disconnected(host, e.peer->address.host, e.peer->address.port, connect_id);
                events_.push_back({ServerConnectionEvent::Type::Disconnected, id, address_text(e.peer->address)});
            }
            e.peer->data = nullptr;
            break;
        }
        case ENET_EVENT_TYPE_RECEIVE:
            deliver(e.peer, e.channelID, {e.packet->data, e.packet->dataLength}, e.packet, now);
            break;
        default: break;
    }
}

void EnetServer::deliver(ENetPeer* peer, std::uint8_t channel, std::span<const std::uint8_t> bytes, ENetPacket* packet, Micros now) {
    const std::uint32_t id = id_of(peer);
    if (channel > kReliableChannel) ++counters_.dropped_bad_channel;
    else if (bytes.size() > kMaxDatagramBytes) ++counters_.dropped_oversized;
    else if (inbox_.size() - inbox_next_ >= config_.max_inbox) ++counters_.dropped_inbox_full;
    else if (id != 0) {
        inbox_.push_back({id, packet, now, bytes});  // a packet is destroyed once taken (release_taken)
        ++counters_.datagrams_in;
        return;
    }
    if (packet) enet_packet_destroy(packet);
}

bool EnetServer::claim_thunk(void* self, std::size_t host, std::uint32_t ip, std::uint16_t port, std::span<const std::uint8_t> d) {
    return static_cast<EnetServer*>(self)->claim(host, ip, port, d);
}

bool EnetServer::claim(std::size_t h, std::uint32_t ip, std::uint16_t port, std::span<const std::uint8_t> d) {
    // Only the common case is taken: a datagram that is one SEND_UNSEQUENCED command, no sent
    // time (nothing reliable inside), not compressed, from its connected peer's address and
    // session. Anything else (connects, acknowledgements, reliable messages, pings, several
    // commands, a stranger's datagram) goes to the host's ENet as before, which drops what it
    // must. ENet's checks for this case (protocol.c, enet_protocol_handle_incoming_commands and
    // _handle_send_unsequenced) are repeated here on the peer's public fields.
    constexpr std::size_t kHeader = sizeof(enet_uint16) + sizeof(ENetProtocolSendUnsequenced);
    if (d.size() < kHeader || h >= hosts_.size()) return false;
    const auto read16 = [&d](std::size_t at) { return static_cast<enet_uint16>((d[at] << 8) | d[at + 1]); };
    const enet_uint16 word = read16(0);
    if ((word & ENET_PROTOCOL_HEADER_FLAG_MASK) != 0) return false;
    if (d[2] != (static_cast<unsigned>(ENET_PROTOCOL_COMMAND_SEND_UNSEQUENCED) | static_cast<unsigned>(ENET_PROTOCOL_COMMAND_FLAG_UNSEQUENCED)))
        return false;
    const std::size_t length = read16(8);
    if (length != d.size() - kHeader) return false;  // exactly one command
    ENetHost* host = hosts_[h];
    const std::size_t index = word & ENET_PROTOCOL_MAXIMUM_PEER_ID;
    if (index >= host->peerCount) return false;
    ENetPeer* peer = &host->peers[index];
    if (peer->state != ENET_PEER_STATE_CONNECTED || peer->address.host != ip || peer->address.port != port) return false;
    const auto session = static_cast<enet_uint8>((word & ENET_PROTOCOL_HEADER_SESSION_MASK) >> ENET_PROTOCOL_HEADER_SESSION_SHIFT);
    if (peer->outgoingPeerID < ENET_PROTOCOL_MAXIMUM_PEER_ID && session != peer->incomingSessionID) return false;
    const std::uint8_t channel = d[3];
    if (channel >= peer->channelCount || length > host->maximumPacketSize) return false;
    // The unsequenced window (enet_protocol_handle_send_unsequenced): a group seen is a repeat.
    enet_uint32 group = read16(6);
    const enet_uint32 slot = group % ENET_PEER_UNSEQUENCED_WINDOW_SIZE;
    if (group < peer->incomingUnsequencedGroup) group += 0x10000;
    if (group >= static_cast<enet_uint32>(peer->incomingUnsequencedGroup) + ENET_PEER_FREE_UNSEQUENCED_WINDOWS * ENET_PEER_UNSEQUENCED_WINDOW_SIZE)
        return false;  // too far ahead: ENet drops it
    group &= 0xFFFF;
    if (group - slot != peer->incomingUnsequencedGroup) {
        peer->incomingUnsequencedGroup = static_cast<enet_uint16>(group - slot);
        std::memset(peer->unsequencedWindow, 0, sizeof peer->unsequencedWindow);
    } else if (peer->unsequencedWindow[slot / 32] & (1u << (slot % 32))) {
        ++counters_.repeats_direct;
        return true;  // a repeat: dropped, as ENet drops it
    }
    peer->unsequencedWindow[slot / 32] |= 1u << (slot % 32);
    host->totalReceivedData += static_cast<enet_uint32>(d.size());
    ++host->totalReceivedPackets;
    peer->incomingDataTotal += static_cast<enet_uint32>(d.size());
    ++counters_.datagrams_in_direct;
    deliver(peer, channel, d.subspan(kHeader), nullptr, poll_now_);
    return true;
}

void EnetServer::abandon_thunk(void* self, std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) {
    static_cast<EnetServer*>(self)->abandon(host, ip, port, connect_id);
}

void EnetServer::abandon(std::size_t h, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) {
    // The client connected again from the slot this handshake came from: it reset that slot, so
    // it will never acknowledge this peer's VERIFY_CONNECT. Left alone, ENet resends the verify
    // to the client's address for up to ENet's 30 s default timeout (our timeouts are set only
    // once connected), holding a slot and a place in duplicatePeers, and a resent verify that
    // finds the client's next connect still pending makes its ENet give that connect up too
    // (a verify's connect id is checked; a connecting peer takes it whatever its session). Only
    // a peer still waiting for the verify's acknowledgement is reset: it has had no event and
    // gets none (as ENet's own reset of a half-open peer). One whose verify was acknowledged has
    // its Connected event queued: its events follow as usual (DatagramDemux::connected counts it).
    if (h >= hosts_.size()) return;
    ENetHost* host = hosts_[h];
    for (std::size_t i = 0; i < host->peerCount; ++i) {
        ENetPeer* p = &host->peers[i];
        if (p->state == ENET_PEER_STATE_ACKNOWLEDGING_CONNECT && p->connectID == connect_id && p->address.host == ip && p->address.port == port) {
            enet_peer_reset(p);
            ++counters_.handshakes_abandoned;
            return;
        }
    }
}

int EnetServer::intercept(ENetHost* host) {
    // Before ENet takes a connect: the handshakes its client gave up end, and the slot it takes
    // gets the handshake timeout (transport/enet_handshakes.h). Nothing is swallowed.
    counters_.handshakes_abandoned += prepare_for_connect(host);
    return 0;
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
    out.bytes = r.bytes;
    out.time_us = r.time_us;
    return true;
}

bool EnetServer::send_unsequenced_now(ENetPeer* peer, std::span<const std::uint8_t> bytes) {
    // The datagram ENet's flush would build for one unsequenced packet: the protocol header (the
    // client's peer id, its session, no sent time: nothing reliable rides along), then one
    // SEND_UNSEQUENCED command with the peer's next unsequenced group, then the bytes. All of
    // it is ENet's public protocol (enet/protocol.h) and the peer's public fields, updated as
    // enet_peer_send and the flush update them.
    if (peer->state != ENET_PEER_STATE_CONNECTED || peer->outgoingPeerID >= ENET_PROTOCOL_MAXIMUM_PEER_ID) return false;
    ENetHost* host = peer->host;
    // A host that checksums or compresses its datagrams builds them itself (EnetServer sets neither).
    if (host->checksum != nullptr || host->compressor.context != nullptr) return false;
    constexpr std::size_t kHeader = sizeof(enet_uint16) + sizeof(ENetProtocolSendUnsequenced);
    if (kHeader + bytes.size() > peer->mtu) return false;  // ENet fragments it
    std::uint8_t head[kHeader];
    const auto put16 = [&head](std::size_t at, enet_uint16 v) {
        const enet_uint16 n = ENET_HOST_TO_NET_16(v);
        std::memcpy(head + at, &n, sizeof n);
    };
    put16(0, static_cast<enet_uint16>(peer->outgoingPeerID | (peer->outgoingSessionID << ENET_PROTOCOL_HEADER_SESSION_SHIFT)));
    head[2] = static_cast<std::uint8_t>(static_cast<unsigned>(ENET_PROTOCOL_COMMAND_SEND_UNSEQUENCED) | static_cast<unsigned>(ENET_PROTOCOL_COMMAND_FLAG_UNSEQUENCED));
    head[3] = kInputChannel;
    put16(4, 0);  // reliableSequenceNumber: none
    put16(6, static_cast<enet_uint16>(peer->outgoingUnsequencedGroup + 1));
    put16(8, static_cast<enet_uint16>(bytes.size()));
    ENetBuffer buffers[2];
    buffers[0].data = head;
    buffers[0].dataLength = kHeader;
    buffers[1].data = const_cast<std::uint8_t*>(bytes.data());
    buffers[1].dataLength = bytes.size();
    const int sent = enet_socket_send(host->socket, &peer->address, buffers, 2);
    if (sent < 0) return false;
    ++peer->outgoingUnsequencedGroup;  // as enet_peer_setup_outgoing_command
    peer->outgoingDataTotal += static_cast<enet_uint32>(bytes.size());
    ++peer->packetsSent;  // as the flush counts each command it sends (ENet's packet loss statistics)
    peer->lastSendTime = host->serviceTime;
    host->totalSentData += static_cast<enet_uint32>(kHeader + bytes.size());
    ++host->totalSentPackets;
    ++counters_.datagrams_direct;
    return true;  // sent == 0 (the socket would block): lost, as an unreliable datagram may be
}

bool EnetServer::send(std::uint32_t connection, std::span<const std::uint8_t> bytes, bool reliable) {
    const auto it = by_id_.find(connection);
    if (it == by_id_.end() || bytes.size() > kMaxDatagramBytes) return false;
    if (!reliable && config_.direct_unsequenced && send_unsequenced_now(it->second.peer, bytes)) {
        ++counters_.datagrams_out;
        return true;
    }
    mark_dirty(it->second.host);
    ENetPacket* p = enet_packet_create(bytes.data(), bytes.size(), reliable ? ENET_PACKET_FLAG_RELIABLE : ENET_PACKET_FLAG_UNSEQUENCED);
    if (p == nullptr || enet_peer_send(it->second.peer, reliable ? kReliableChannel : kInputChannel, p) != 0) {
        if (p) enet_packet_destroy(p);
        ++counters_.send_failures;
        return false;
    }
    ++counters_.datagrams_out;
    return true;
}

void EnetServer::flush() {
    if (!fanout_) {
        enet_host_flush(hosts_[0]);
        ++counters_.host_flushes;
        return;
    }
    for (std::size_t h : dirty_list_)
        if (dirty_[h]) {
            enet_host_flush(hosts_[h]);
            ++counters_.host_flushes;
            dirty_[h] = 0;
        }
    dirty_list_.clear();
}

void EnetServer::disconnect(std::uint32_t connection) {
    const auto it = by_id_.find(connection);
    if (it == by_id_.end()) return;
    enet_peer_disconnect_later(it->second.peer, 0);
    mark_dirty(it->second.host);
}

int EnetServer::socket_fd() const { return static_cast<int>(hosts_[0]->socket); }
std::uint64_t EnetServer::wire_bytes_sent() const {
    std::uint64_t n = 0;
    for (const auto* h : hosts_) n += h->totalSentData;
    return n;
}
std::uint64_t EnetServer::wire_bytes_received() const {
    std::uint64_t n = 0;
    for (const auto* h : hosts_) n += h->totalReceivedData;
    return n;
}

}  // namespace lockroll::transport
