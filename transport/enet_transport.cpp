#include "transport/enet_transport.h"

#include <enet/enet.h>

#include "transport/enet_library.h"
#include "transport/enet_stale_verify.h"

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

namespace lockroll::transport {

namespace {

constexpr enet_uint8 kInputChannel = 0;     // unreliable unsequenced
constexpr enet_uint8 kReliableChannel = 1;  // reliable, ordered
constexpr std::size_t kChannels = 2;

// Bounds on one poll(), so a flood cannot keep it busy: ENet events handled, service errors
// skipped, and service calls that return nothing before we conclude the socket is drained
// (each call reads up to 256 datagrams; junk yields no event).
constexpr int kMaxEventsPerPoll = 4096;
constexpr int kMaxErrorsPerPoll = 1024;
constexpr int kIdleCallsPerPoll = 2;

// ENet timeouts an established connection never reaches (EnetConfig::dead_after_us ends it):
// a retry count whose power of two no send attempt count reaches, and an hour.
constexpr enet_uint32 kNeverTimeoutLimit = 1u << 30;
constexpr enet_uint32 kNeverTimeoutMs = 3'600'000;

// Disconnect data we send, so the other side can say why (0 is ENet's: timeout or plain close).
enum CloseCode : enet_uint32 {
    kTimedOut = 0,          // silent for dead_after_us (ENet's own timeout sends nothing: also 0)
    kClosed = 1,            // orderly shutdown (destructor)
    kRefusedOwnId = 2,      // you claimed my own id
    kRefusedDuplicate = 3,  // your id is held by a live connection (refused; or your claim is void:
                            // the silent connection you claimed spoke again)
    kCrossed = 4,           // both connected at once; the one the lower id initiated is kept
    kReplaced = 5,          // a connection claiming your id took it over: this one stayed silent
};

std::string close_reason(enet_uint32 code) {
    switch (code) {
        case kClosed: return "closed by the peer";
        case kRefusedOwnId: return "refused by the peer: we claimed its own id";
        case kRefusedDuplicate: return "refused by the peer: our id is held by another live connection";
        case kCrossed: return "crossed connect: the peer keeps the connection the lower id initiated";
        case kReplaced: return "the peer replaced this connection with a newer one claiming our id";
        default: return "timed out or closed";
    }
}


void configure_peer(ENetPeer* peer) {
    // Deceleration 0: ENet never lowers the packet throttle, so it never discards our
    // unreliable input packets on its own; loss handling is the session's (redundant resends).
    enet_peer_throttle_configure(peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
}

// The transport whose host is inside enet_host_service on this thread: ENet's intercept
// callback has no user pointer.
thread_local EnetTransport* t_servicing = nullptr;

int ENET_CALLBACK intercept_callback(ENetHost* host, ENetEvent* /*event*/) {
    return t_servicing != nullptr ? t_servicing->intercept(host) : 0;
}

std::uint16_t read_be16(const enet_uint8* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

}  // namespace

EnetTransport::EnetTransport(const EnetConfig& config) : config_(config), local_id_(config.local_id) {
    if (config.max_peers < 1 || config.max_peers > ENET_PROTOCOL_MAXIMUM_PEER_ID)
        throw std::invalid_argument("EnetTransport: max_peers must be 1.." + std::to_string(ENET_PROTOCOL_MAXIMUM_PEER_ID));
    if (config.max_connections_per_address < 1)
        throw std::invalid_argument("EnetTransport: max_connections_per_address must be >= 1");
    if (config.max_packet_bytes < kMaxDatagramBytes)
        throw std::invalid_argument("EnetTransport: max_packet_bytes must be >= " + std::to_string(kMaxDatagramBytes));
    ensure_enet_initialized();
    const std::string where = config.bind_host + ":" + std::to_string(config.port);
    ENetAddress address{};
    if (enet_address_set_host(&address, config.bind_host.c_str()) != 0)
        throw std::runtime_error("ENet: cannot resolve bind address " + where);
    address.port = config.port;
    host_ = enet_host_create(&address, config.max_peers, kChannels, 0, 0);
    if (host_ == nullptr) throw std::runtime_error("ENet: cannot create a host bound to " + where);
    host_->duplicatePeers = config.max_connections_per_address;
    host_->maximumPacketSize = config.max_packet_bytes;
    host_->maximumWaitingData = config.max_waiting_bytes;
    host_->intercept = intercept_callback;
    ENetAddress bound{};
    port_ = enet_socket_get_address(host_->socket, &bound) == 0 ? bound.port : config.port;
}

EnetTransport::~EnetTransport() {
    for (auto& [id, conn] : by_id_) enet_peer_disconnect_now(conn.peer, kClosed);
    for (auto& [id, conn] : claimants_) enet_peer_disconnect_now(conn.peer, kClosed);
    enet_host_flush(host_);
    enet_host_destroy(host_);
}

int EnetTransport::intercept(ENetHost* host) {
    // An answer to a connect one of our slots gave up would end the connect it has pending now
    // (transport/enet_stale_verify.h): it is ignored.
    if (is_stale_verify_connect(host)) {
        ++enet_counters_.dropped_stale_verify;
        return 1;
    }
    // Otherwise only connect requests matter here: a datagram whose header names no peer (peer id
    // ENET_PROTOCOL_MAXIMUM_PEER_ID) and whose first command is CONNECT. ENet parses the rest.
    const enet_uint8* data = host->receivedData;
    const std::size_t size = host->receivedDataLength;
    if (size < 2) return 0;
    const std::uint16_t header = read_be16(data);
    if ((header & ENET_PROTOCOL_HEADER_FLAG_COMPRESSED) != 0) return 0;
    if ((header & ~(ENET_PROTOCOL_HEADER_FLAG_MASK | ENET_PROTOCOL_HEADER_SESSION_MASK)) != ENET_PROTOCOL_MAXIMUM_PEER_ID)
        return 0;
    const std::size_t header_size = (header & ENET_PROTOCOL_HEADER_FLAG_SENT_TIME) != 0 ? 4 : 2;
    if (size < header_size + sizeof(ENetProtocolConnect)) return 0;
    const enet_uint8* command = data + header_size;
    if ((command[0] & ENET_PROTOCOL_COMMAND_MASK) != ENET_PROTOCOL_COMMAND_CONNECT) return 0;
    // ENet keeps connectID as it came off the wire; compare the same raw bytes.
    enet_uint32 connect_id = 0;
    std::memcpy(&connect_id, command + offsetof(ENetProtocolConnect, connectID), sizeof connect_id);

    // The rule of enet_protocol_handle_connect, so that what it would refuse silently is
    // counted here instead.
    std::size_t same_address = 0;
    bool free_slot = false;
    for (std::size_t i = 0; i < host->peerCount; ++i) {
        const ENetPeer& p = host->peers[i];
        if (p.state == ENET_PEER_STATE_DISCONNECTED) {
            free_slot = true;
        } else if (p.state != ENET_PEER_STATE_CONNECTING && p.address.host == host->receivedAddress.host) {
            if (p.address.port == host->receivedAddress.port && p.connectID == connect_id) return 0;  // a resend
            ++same_address;
        }
    }
    if (same_address >= config_.max_connections_per_address) {
        ++enet_counters_.refused_address_limit;
        ++counters_.rejected;
        return 1;
    }
    if (!free_slot) {
        ++enet_counters_.refused_no_slot;
        ++counters_.rejected;
        return 1;
    }
    return 0;
}

bool EnetTransport::silent(const Connection& c) const {
    return last_now_ >= c.last_heard_us && last_now_ - c.last_heard_us >= config_.silent_after_us;
}

void EnetTransport::push_event(TransportEvent::Type type, PeerId peer, std::string reason) {
    if (events_.size() >= config_.max_events) {
        ++enet_counters_.dropped_events;
        return;
    }
    events_.push_back(TransportEvent{type, peer, std::move(reason)});
}

bool EnetTransport::next_event(TransportEvent& out) {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

void EnetTransport::refuse(ENetPeer* peer, std::uint32_t code) { enet_peer_disconnect_now(peer, code); }

void EnetTransport::drop_connection(std::map<PeerId, Connection>& from, PeerId id, std::uint32_t code) {
    const auto it = from.find(id);
    if (it == from.end()) return;
    by_peer_.erase(it->second.peer);
    // A connection given up for its silence (replaced by a new claim, or timed out) is forgotten
    // without a word: its process is probably dead, and its address may already be its
    // successor's (a restarted process binds its old port). ENet tells connections apart by
    // slot, address and a 2-bit session id, which a fresh process's first connections repeat,
    // so a disconnect sent here closed the successor's new connection (issue 21: a rejoining
    // slot 0 lost every connection it made that way; enet_same_address_restart_test).
    if (code == kReplaced || code == kTimedOut)
        enet_peer_reset(it->second.peer);
    else
        enet_peer_disconnect_now(it->second.peer, code);  // resets the slot; no event for it here
    from.erase(it);
}

EnetTransport::Connection* EnetTransport::connection_of(ENetPeer* peer, PeerId* id, bool* claimant) {
    const auto it = by_peer_.find(peer);
    if (it == by_peer_.end()) return nullptr;
    *id = it->second;
    if (claimant != nullptr) *claimant = false;
    if (const auto h = by_id_.find(it->second); h != by_id_.end() && h->second.peer == peer) return &h->second;
    if (claimant != nullptr) *claimant = true;
    if (const auto c = claimants_.find(it->second); c != claimants_.end() && c->second.peer == peer) return &c->second;
    return nullptr;
}

void EnetTransport::held_gone(PeerId id, std::uint32_t close_code, std::string why) {
    const auto c = claimants_.find(id);
    if (c == claimants_.end()) {
        drop_connection(by_id_, id, close_code);
        ++enet_counters_.disconnects;
        push_event(TransportEvent::Type::Disconnected, id, std::move(why));
        return;
    }
    // The claim stood: the old connection was never heard again. Its claimant holds the id now.
    drop_connection(by_id_, id, kReplaced);
    ++enet_counters_.replaced;
    const bool up = c->second.established;
    by_id_[id] = c->second;  // by_peer_ already names its peer with the id
    by_id_[id].claimed_us = 0;
    claimants_.erase(c);
    if (up)
        push_event(TransportEvent::Type::Connected, id, "reconnected: the claim stood; replaces a connection " + why);
    else  // our own connect is still under way: a Connected follows when it completes
        push_event(TransportEvent::Type::Disconnected, id, std::move(why));
}

bool EnetTransport::connect(PeerId remote, const std::string& host, std::uint16_t port, std::string* error) {
    const auto fail = [&](std::string why) {
        if (error) *error = std::move(why);
        return false;
    };
    if (remote == local_id_) return fail("peer id " + std::to_string(remote) + " is the local id");
    // A silent connection is not closed: the new one claims its id, provisionally (the header).
    bool claim = false;
    if (const auto it = by_id_.find(remote); it != by_id_.end()) {
        if (!it->second.established || !silent(it->second) || claimants_.count(remote) != 0)
            return fail("peer id " + std::to_string(remote) + " is already connected or connecting");
        claim = true;
    }
    ENetAddress address{};
    if (enet_address_set_host(&address, host.c_str()) != 0) return fail("cannot resolve host '" + host + "'");
    address.port = port;
    ENetPeer* peer = enet_host_connect(host_, &address, kChannels, local_id_);
    if (peer == nullptr) return fail("no free ENet connection slot");
    Connection c{peer, false, true, last_now_, peer->lastReceiveTime};
    if (claim) {
        c.claimed_us = last_now_;
        claimants_[remote] = c;
        ++enet_counters_.replace_claims;
    } else {
        by_id_[remote] = c;
    }
    by_peer_[peer] = remote;
    return true;
}

std::uint64_t EnetTransport::wire_bytes_sent() const { return host_->totalSentData; }
std::uint64_t EnetTransport::wire_bytes_received() const { return host_->totalReceivedData; }

bool EnetTransport::is_connected(PeerId remote) const {
    const auto it = by_id_.find(remote);
    const auto c = claimants_.find(remote);
    return (it != by_id_.end() && it->second.established) || (c != claimants_.end() && c->second.established);
}

std::vector<PeerId> EnetTransport::connected_peers() const {
    std::vector<PeerId> ids;
    for (const auto& [id, conn] : by_id_)
        if (is_connected(id)) ids.push_back(id);
    return ids;
}

void EnetTransport::handle_connect(const ENetEvent& event, Micros now) {
    ENetPeer* peer = event.peer;
    PeerId ours = 0;
    bool claimant = false;
    if (Connection* c = connection_of(peer, &ours, &claimant)) {  // our outgoing connect completed
        c->established = true;
        c->last_heard_us = now;
        c->enet_last_receive = peer->lastReceiveTime;  // the handshake itself is not a first word
        c->up_us = now;
        configure_peer(peer);
        push_event(TransportEvent::Type::Connected, ours,
                   claimant ? "reconnected (we connected; provisional: the silent connection it claims stays open)"
                       : "connected (we connected)");
        return;
    }
    const PeerId remote = event.data;
    const std::string who = "peer " + std::to_string(remote) + " from port " + std::to_string(peer->address.port);
    if (remote == local_id_) {
        ++enet_counters_.refused_own_id;
        ++counters_.rejected;
        refuse(peer, kRefusedOwnId);
        push_event(TransportEvent::Type::Refused, remote, who + " claimed our own id");
        return;
    }
    std::string reason = "connected (it connected)";
    if (const auto it = by_id_.find(remote); it != by_id_.end()) {
        const Connection& old = it->second;
        if (old.established && silent(old)) {
            // A claim: admitted beside the silent connection, which stays open and keeps the
            // id if it is heard again (poll()). A claimant that went silent itself gives way.
            if (const auto c = claimants_.find(remote); c != claimants_.end()) {
                if (!c->second.established || !silent(c->second)) {
                    ++enet_counters_.refused_duplicate_id;
                    ++counters_.rejected;
                    refuse(peer, kRefusedDuplicate);
                    push_event(TransportEvent::Type::Refused, remote,
                               who + ": id claimed by another live connection already");
                    return;
                }
                drop_connection(claimants_, remote, kReplaced);
            }
            ++enet_counters_.replace_claims;
            Connection c{peer, true, false, now, peer->lastReceiveTime, true};
            c.claimed_us = now;
            claimants_[remote] = c;
            by_peer_[peer] = remote;
            configure_peer(peer);
            push_event(TransportEvent::Type::Connected, remote,
                       "reconnected (provisional): claims an id whose connection is silent for " +
                           std::to_string((now - old.last_heard_us) / 1000) +
                           " ms; that connection stays open and keeps the id if heard again");
            return;
        }
        if (old.outgoing) {
            // Crossed connects: keep the one initiated by the lower id, the same on both sides.
            ++enet_counters_.crossed_connects;
            if (remote > local_id_) {
                refuse(peer, kCrossed);
                return;
            }
            drop_connection(by_id_, remote, kCrossed);
            reason = "connected (crossed connects: kept the one the lower id initiated)";
        } else {
            ++enet_counters_.refused_duplicate_id;
            ++counters_.rejected;
            refuse(peer, kRefusedDuplicate);
            push_event(TransportEvent::Type::Refused, remote, who + ": id held by a live connection");
            return;
        }
    }
    by_id_[remote] = Connection{peer, true, false, now, peer->lastReceiveTime, true};
    by_peer_[peer] = remote;
    configure_peer(peer);
    push_event(TransportEvent::Type::Connected, remote, reason);
}

void EnetTransport::handle(const ENetEvent& event, Micros now) {
    switch (event.type) {
        case ENET_EVENT_TYPE_CONNECT:
            handle_connect(event, now);
            return;
        case ENET_EVENT_TYPE_RECEIVE: {
            PeerId from = 0;
            Connection* c = connection_of(event.peer, &from);
            const std::size_t size = event.packet->dataLength;
            std::uint64_t* drop = nullptr;
            if (c == nullptr || !c->established)
                drop = &enet_counters_.dropped_unknown_peer;
            else if (event.channelID != kInputChannel && event.channelID != kReliableChannel)
                drop = &enet_counters_.dropped_bad_channel;
            else if (size > kMaxDatagramBytes)
                drop = &enet_counters_.dropped_oversized;
            else if (inbox_.size() >= config_.max_inbox)
                drop = &enet_counters_.dropped_inbox_full;
            if (drop != nullptr) {
                ++*drop;
                ++counters_.rejected;
            } else {
                c->last_heard_us = now;
                c->heard_since_up = true;
                Datagram d;
                d.from = from;  // a claimant's too: the session weighs claims (docs/sessions.md)
                d.time_us = now;
                d.bytes.assign(event.packet->data, event.packet->data + size);
                d.reliable = event.channelID == kReliableChannel;
                inbox_.push_back(std::move(d));
            }
            enet_packet_destroy(event.packet);
            return;
        }
        case ENET_EVENT_TYPE_DISCONNECT: {
            PeerId id = 0;
            bool claimant = false;
            const Connection* c = connection_of(event.peer, &id, &claimant);
            if (c == nullptr) return;  // a refused or replaced connection
            if (claimant) {
                // A claimant gave up: the id still has its connection, so no event.
                by_peer_.erase(event.peer);
                claimants_.erase(id);
                ++enet_counters_.disconnects;
                return;
            }
            // kCrossed: usually the peer's own connection is on its way (a Connected follows);
            // but if we are a restarted process whose old connection the peer still thinks
            // alive, nothing follows, and the runner should connect() again in a second.
            // ENet has reset the slot already; disconnecting it again sends nothing.
            held_gone(id, kClosed, (c->established ? "" : "could not connect: ") + close_reason(event.data));
            return;
        }
        case ENET_EVENT_TYPE_NONE:
            return;
    }
}

void EnetTransport::poll(Micros now) {
    last_now_ = now;
    // ENet restores its default timeouts (30 s) whenever it resets a slot, and half-open
    // connections take a slot without ever producing an event: set ours on every slot, always.
    // Established connections are ended by our silence rule instead (dead_after_us), so theirs
    // are out of reach: no more retries than ENet can count, an hour.
    for (std::size_t i = 0; i < host_->peerCount; ++i)
        enet_peer_timeout(&host_->peers[i], config_.timeout_limit, config_.timeout_min_ms, config_.timeout_max_ms);
    for (const auto* connections : {&by_id_, &claimants_})
        for (const auto& [id, c] : *connections)
            if (c.established) enet_peer_timeout(c.peer, kNeverTimeoutLimit, kNeverTimeoutMs, kNeverTimeoutMs);

    t_servicing = this;
    ENetEvent event;
    int events = 0, errors = 0, idle = 0;
    while (events < kMaxEventsPerPoll && errors < kMaxErrorsPerPoll && idle < kIdleCallsPerPoll) {
        const int r = enet_host_service(host_, &event, 0);
        if (r < 0) {
            // The datagram that caused it is consumed; keep serving the ones behind it.
            ++errors;
            ++enet_counters_.receive_errors;
        } else if (r == 0) {
            ++idle;
        } else {
            idle = 0;
            ++events;
            handle(event, now);
        }
    }
    t_servicing = nullptr;

    // Anything ENet heard from a connection (datagrams, pings, acknowledgements) moves its
    // lastReceiveTime; we only compare it for change and time silence on the caller's clock.
    const auto dead_ids = [&](std::map<PeerId, Connection>& connections) {
        std::vector<PeerId> dead;
        for (auto& [id, c] : connections) {
            if (c.peer->lastReceiveTime != c.enet_last_receive) {
                c.enet_last_receive = c.peer->lastReceiveTime;
                c.last_heard_us = now;
                // ENet moves it once more while finishing the handshake, in the poll that
                // reports the connection up: not a word from the peer yet.
                c.heard_since_up = c.heard_since_up || (c.established && now != c.up_us);
            }
            const bool first_word_due = c.outgoing && !c.heard_since_up && config_.first_word_after_us > 0;
            const Micros limit =
                first_word_due ? std::min(config_.first_word_after_us, config_.dead_after_us) : config_.dead_after_us;
            if (c.established && now >= c.last_heard_us && now - c.last_heard_us >= limit) dead.push_back(id);
        }
        return dead;
    };
    const std::vector<PeerId> dead_held = dead_ids(by_id_);
    const std::vector<PeerId> dead_claimants = dead_ids(claimants_);

    // A claim is void once the connection it claimed is heard again (issue 21): the old process
    // is alive, so the id stays with it and the claimant is closed.
    std::vector<PeerId> voided;
    for (const auto& [id, c] : claimants_)
        if (by_id_.at(id).last_heard_us >= c.claimed_us) voided.push_back(id);
    for (const PeerId id : voided) {
        const Connection& c = claimants_.at(id);
        const std::string why = "peer " + std::to_string(id) + " from port " + std::to_string(c.peer->address.port) +
                                ": id held by a live connection (it was heard again " +
                                std::to_string((by_id_.at(id).last_heard_us - c.claimed_us) / 1000) + " ms into the claim)";
        drop_connection(claimants_, id, kRefusedDuplicate);
        ++enet_counters_.claims_voided;
        ++counters_.rejected;
        push_event(TransportEvent::Type::Refused, id, why);
    }
    // A silent claimant just goes: its id still has its connection. Then a silent connection
    // goes, and its claimant, if one stands, takes the id over (held_gone).
    for (const PeerId id : dead_claimants) {
        if (claimants_.count(id) == 0) continue;
        drop_connection(claimants_, id, kTimedOut);
        ++enet_counters_.disconnects;
    }
    for (const PeerId id : dead_held) {
        const Connection& c = by_id_.at(id);
        std::string why = (c.heard_since_up ? "timed out: silent for " : "timed out: not a word since connected, ") +
                          std::to_string((now - c.last_heard_us) / 1000) + " ms";
        held_gone(id, kTimedOut, std::move(why));
    }
}

bool EnetTransport::send_on(PeerId to, std::span<const std::uint8_t> bytes, bool reliable) {
    // To the id's connection and to its claimant, if one stands: whichever is the live process
    // hears it (the session tells a new incarnation from the old by its hello).
    std::vector<ENetPeer*> peers;
    for (const auto* connections : {&by_id_, &claimants_})
        if (const auto it = connections->find(to); it != connections->end() && it->second.established)
            peers.push_back(it->second.peer);
    if (peers.empty() || bytes.size() > kMaxDatagramBytes) {
        if (bytes.size() > kMaxDatagramBytes) ++enet_counters_.dropped_oversized;
        ++counters_.rejected;
        return false;
    }
    ++counters_.datagrams_sent;
    counters_.bytes_sent += bytes.size();
    ENetPacket* packet =
        enet_packet_create(bytes.data(), bytes.size(), reliable ? ENET_PACKET_FLAG_RELIABLE : ENET_PACKET_FLAG_UNSEQUENCED);
    if (packet == nullptr) {
        ++counters_.dropped;
        return true;
    }
    bool queued = false;
    for (ENetPeer* peer : peers)
        queued = enet_peer_send(peer, reliable ? kReliableChannel : kInputChannel, packet) == 0 || queued;
    if (!queued) {
        // Not queued: ENet did not take ownership.
        if (packet->referenceCount == 0) enet_packet_destroy(packet);
        ++counters_.dropped;
        return true;
    }
    enet_host_flush(host_);
    return true;
}

bool EnetTransport::send(PeerId to, std::span<const std::uint8_t> bytes, Micros /*now*/) {
    return send_on(to, bytes, false);
}

bool EnetTransport::send_reliable(PeerId to, std::span<const std::uint8_t> bytes, Micros /*now*/) {
    return send_on(to, bytes, true);
}

bool EnetTransport::receive(Datagram& out, Micros now) {
    if (inbox_.empty()) poll(now);
    if (inbox_.empty()) return false;
    Datagram& front = inbox_.front();
    out.from = front.from;
    out.time_us = front.time_us;
    out.reliable = front.reliable;
    out.bytes.swap(front.bytes);
    inbox_.pop_front();
    ++counters_.datagrams_received;
    counters_.bytes_received += out.bytes.size();
    return true;
}

}  // namespace lockroll::transport
