// DatagramDemux: which of several ENet hosts sharing one UDP socket a datagram is for
// (lockroll-server's shared socket: server/enet_socket_batching.h, transport/enet_server.h).
//
// ENet walks every connection slot of a host each time the host is serviced (its acks, timeouts,
// pings and sends), so one host of thousands of connections pays thousands of slot visits per
// pass whatever the pass carries (docs/performance.md, "Density"). Several small hosts behind the
// one socket let the server service only the hosts that have traffic. To the clients they are
// one ENet host of hosts x capacity connections: host k's peer i is the server's peer
// k x capacity + i, the id the client puts in every datagram's header (ENet's own routing). So:
//  - a datagram naming a server peer goes to that peer's host, its header rewritten to the
//    host's own index (route()); that host's ENet then checks the sender's address and session
//    as one host always did. Nothing else in a datagram chooses a host: a datagram with another
//    connection's peer id (a spoof) reaches that connection's host, which drops it for its
//    address, and a connection never moves;
//  - an ENet connect (the peer id unassigned, the command CONNECT) goes to the least-loaded host
//    (connections + handshakes; the lowest index on a tie), and the connect's repeats (same
//    address, same connect id) to the same host while the handshake may last (pending_us) and
//    while the connection it made lasts (one host drops a repeat of a connect it holds: so does
//    that host);
//    a connect from an IP holding max_per_ip connections and handshakes is dropped, as one ENet
//    host drops it past its duplicatePeers, and so is one that finds every host full;
//  - a new connect from the address and client peer slot (the connect's outgoingPeerID) of a
//    handshake not yet connected abandons that handshake: an ENet client slot holds one
//    connection, so the client gave the old one up (it reset the slot). Its count is released at
//    once and it is reported (next_abandoned()) so that its host's ENet peer, which would
//    otherwise resend its VERIFY_CONNECT to the client until its handshake timeout
//    (kHandshakeTimeoutMs, transport/enet_handshakes.h; ENet's default was 30 s) and hold the
//    IP's count as long, is reset too (issue 20: a client cycling connects from one port filled its IP's
//    max_per_ip with such handshakes and locked the IP out for 30 s, honest clients behind it too);
//  - anything else with no peer id is dropped (ENet takes nothing else from an unknown sender);
//  - the server's answer to a connect (VERIFY_CONNECT) names the host's peer index: outgoing()
//    rewrites it to the server's id. Nothing else ENet sends names a server peer.
// Memory: one entry per handshake or connection, bounded by the hosts' capacity; connections
// and handshakes are counted per host and per IP (connected() / disconnected(), from ENet's events).
// IPv4 in network byte order (ENet 1.3 speaks IPv4 only). Not thread-safe; reads no clock.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

namespace lockroll::server {

struct DatagramDemuxConfig {
    std::size_t hosts = 1;
    std::size_t capacity_per_host = 1;      // connections one host holds (its ENet peer count)
    std::size_t connections = 0;            // all hosts together (0: hosts x capacity); the last host holds the rest
    std::size_t max_per_ip = 64;            // connections + handshakes per IP, over all hosts
    std::uint64_t pending_us = 30'000'000;  // how long a handshake's repeats go to its host
};

struct DatagramDemuxCounters {
    std::uint64_t peers = 0;            // routed by the peer id they name
    std::uint64_t connects = 0;         // new connects, routed to the least-loaded host
    std::uint64_t connect_repeats = 0;  // repeats of a connect, routed to its host
    std::uint64_t dropped_unknown = 0;  // no peer id and not a connect, or a peer id nobody has
    std::uint64_t dropped_limit = 0;    // a connect past max_per_ip
    std::uint64_t dropped_full = 0;     // a connect while every host is full
    std::uint64_t abandoned = 0;        // handshakes a new connect from their client slot replaced
};

// A handshake a new connect from its client slot replaced: its host's ENet peer is to be reset.
struct AbandonedHandshake {
    std::size_t host = 0;
    std::uint32_t ip = 0;
    std::uint16_t port = 0;
    std::uint32_t connect_id = 0;
};

class DatagramDemux {
public:
    static constexpr int kDrop = -1;
    // Throws std::invalid_argument on zero hosts or capacity, or more than ENet's 4,095 peer ids.
    explicit DatagramDemux(const DatagramDemuxConfig& config);

    // The host for a datagram from ip:port (its bytes, ENet's header first), or kDrop. A datagram
    // naming a server peer has that id rewritten in place to the host's own peer index.
    int route(std::uint32_t ip, std::uint16_t port, std::span<std::uint8_t> datagram, std::uint64_t now_us);
    // A datagram host `host` sends (its bytes, ENet's header first): its VERIFY_CONNECT's peer
    // index rewritten to the server's id.
    void outgoing(std::size_t host, std::span<std::uint8_t> datagram) const;
    // ENet connected (a peer of `host` reached Connected; connect_id: ENetPeer::connectID, as
    // its connect carried it) / disconnected one.
    void connected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id);
    void disconnected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id);

    // Connections and handshakes held by a host.
    std::size_t load(std::size_t host) const { return load_[host]; }
    std::size_t capacity(std::size_t host) const { return host + 1 < load_.size() ? config_.capacity_per_host : last_capacity_; }
    std::size_t hosts() const { return load_.size(); }
    std::size_t handshakes() const { return handshakes_.size() - connections_; }
    const DatagramDemuxCounters& counters() const { return counters_; }
    // The handshakes route() abandoned, oldest first, each once (false: none left).
    bool next_abandoned(AbandonedHandshake& out);
    // The connect id of an ENet connect (the peer id unassigned, the first command CONNECT) and
    // the client's peer slot it comes from (its outgoingPeerID).
    static bool is_connect(std::span<const std::uint8_t> datagram, std::uint32_t& connect_id, std::uint16_t& client_peer);
    static bool is_connect(std::span<const std::uint8_t> datagram, std::uint32_t& connect_id) {
        std::uint16_t client_peer = 0;
        return is_connect(datagram, connect_id, client_peer);
    }

private:
    struct Handshake {
        std::uint32_t host = 0;
        std::uint16_t client_peer = 0;
        std::uint64_t until = 0;  // 0: connected
    };
    struct Key {
        std::uint64_t address;  // ip << 16 | port
        std::uint32_t connect_id;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        std::size_t operator()(const Key& k) const { return std::hash<std::uint64_t>{}(k.address * 0x9E3779B97F4A7C15ull ^ k.connect_id); }
    };
    static Key key(std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) {
        return {(std::uint64_t{ip} << 16) | port, connect_id};
    }
    // A client slot: the address and the client's peer index (12 bits).
    static std::uint64_t slot(const Key& k, std::uint16_t client_peer) { return k.address << 12 | (client_peer & 0xFFFu); }
    void forget_slot(const Key& k, const Handshake& h);  // h no longer pending
    void expire(std::uint64_t now_us);
    void release(std::size_t host, std::uint32_t ip);  // one connection or handshake less

    DatagramDemuxConfig config_;
    std::size_t last_capacity_;
    std::unordered_map<Key, Handshake, KeyHash> handshakes_;  // and connections (until 0)
    std::size_t connections_ = 0;
    std::unordered_map<std::uint32_t, std::uint32_t> per_ip_;
    std::vector<std::size_t> load_;
    std::deque<std::pair<std::uint64_t, Key>> pending_;  // (until, key), oldest first
    std::unordered_map<std::uint64_t, std::uint32_t> slots_;  // client slot -> its pending handshake's connect id
    std::deque<AbandonedHandshake> abandoned_;
    DatagramDemuxCounters counters_;
};

}  // namespace lockroll::server
