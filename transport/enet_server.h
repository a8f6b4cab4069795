// EnetServer: the accepting side of a star (the relay server's sockets). Unlike EnetTransport,
// which names every connection by the peer id its owner claims (a mesh of cooperating peers),
// it names connections by ids it assigns itself, in order of arrival: nothing a client sends
// decides who it is. Built for thousands of connections on one host:
//  - send() queues reliable datagrams; flush() sends everything queued in one pass over the
//    host (EnetTransport flushes on every send, which is a pass over every connection each
//    time), and so does the next poll() before it waits: a loop that polls again at once need
//    not flush (ENet walks every connection slot on each flush, used or not). Unreliable ones
//    leave at once, as the datagram ENet would send, and with a fanout a client's unsequenced
//    datagrams are taken before their host's ENet reads them (EnetServerConfig::direct_unsequenced);
//  - poll(now, wait_us) waits in the socket up to wait_us for the first datagram (no busy spin,
//    no sleep granularity added to the relay delay), then drains what is there, bounded;
//  - connections are limited in number, per address, in packet size and in waiting data, as
//    EnetTransport's are (docs/network-model.md); a handshake gives up after seconds, not ENet's
//    30 s, and one its client gave up (it connected again from the same slot) ends at once
//    (transport/enet_handshakes.h).
// Channels as EnetTransport: 0 unreliable unsequenced, 1 reliable ordered.
// Not thread-safe; reads no clock (now is passed in).
#pragma once

#include <cstdint>
#include <deque>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "transport/transport.h"

struct _ENetHost;
struct _ENetPeer;
struct _ENetEvent;
struct _ENetPacket;

namespace lockroll::transport {

// Several ENet hosts behind the one UDP socket (EnetServerConfig::connections_per_host): ENet walks
// every connection slot of a host each time it services the host (acks, timeouts, pings, sends),
// so one host of thousands of connections pays thousands of slot visits per pass whatever the pass
// carries. With small hosts sharing the socket, a pass services only the hosts that received a
// datagram, have something queued, or have not been serviced for idle_service_ms; ENet's protocol
// on the wire is unchanged (every host speaks through the same address). The process provides
// the routing (lockroll-server: server/enet_socket_batching.h, which reads the socket in batches
// and routes by the sender's address, server/datagram_demux.h); EnetServer creates the hosts.
class SocketFanout {
public:
    virtual ~SocketFanout() = default;
    // Takes over `socket` (host 0's, bound) for `hosts` ENet hosts of `capacity` connections each
    // (`connections` in all: the last holds the rest; at most max_per_address from one IP over all
    // of them). Returns the socket id each host is
    // to use (ids[0] == socket; the others are ids of the fanout's, no file descriptor), or an
    // empty vector and why not in `why` (EnetServer then keeps one host).
    virtual std::vector<int> attach(int socket, std::size_t hosts, std::size_t capacity, std::size_t connections,
                                    std::size_t max_per_address, std::string& why) = 0;
    // Reads what waits on the socket (bounded) and hands each datagram to its host's queue;
    // appends the hosts that now hold datagrams (each once) to `ready`.
    virtual void receive(std::uint64_t now_us, std::vector<std::size_t>& ready) = 0;
    // Datagrams routed to `host` that it has not read yet (they are gone at the next receive()).
    virtual bool holds(std::size_t host) const = 0;
    // ENet connected / disconnected a peer of `host` at ip:port (as ENetAddress: the IP in network
    // byte order, the port in host byte order), whose connect carried connect_id (ENetPeer::connectID).
    virtual void connected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) = 0;
    virtual void disconnected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) = 0;
    // A datagram its host's ENet need not read (EnetServerConfig::direct_unsequenced): once set,
    // receive() offers each datagram it routed to `host` to claim(context, host, ip, port, bytes)
    // first (ip in network byte order, port in host byte order, the header already rewritten
    // to the host's own peer index); one claimed (true) is not queued for the host, and its
    // bytes stay valid until the next receive(). nullptr: none offered. Default: no claims.
    using Claim = bool (*)(void* context, std::size_t host, std::uint32_t ip, std::uint16_t port, std::span<const std::uint8_t> datagram);
    virtual void set_claim(Claim claim, void* context) {
        (void)claim;
        (void)context;
    }
    // A handshake the client gave up (it connected again from the same address and client peer
    // slot, server/datagram_demux.h) whose ENet peer on `host` is to be reset: once set, receive()
    // calls abandon(context, host, ip, port, connect_id) for each, before it queues the datagram
    // that replaced it. nullptr: none reported. Default: none.
    using Abandon = void (*)(void* context, std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id);
    virtual void set_abandon(Abandon abandon, void* context) {
        (void)abandon;
        (void)context;
    }
};

struct EnetServerConfig {
    std::string bind_host = "127.0.0.1";
    std::uint16_t port = 0;                       // 0: an ephemeral port (see port())
    std::size_t max_connections = 4000;           // ENet allows at most 4095
    std::size_t max_connections_per_address = 64; // a load test from one address raises it
    std::size_t max_packet_bytes = 4096;
    std::size_t max_waiting_bytes = 64 * 1024;
    // ENet's own timeouts (enet_peer_timeout) of established connections (a handshake has
    // kHandshakeTimeoutMs, transport/enet_handshakes.h), left at ENet's defaults: a lossy link must not
    // close a connection under a client that still talks (a reliable ping lost five times in a
    // row at 10 % loss each way is one in 4,000). Dead clients are noticed by the rooms'
    // silence rule (RoomConfig::silence_drop_us, 5 s) long before.
    std::uint32_t timeout_limit = 32;
    std::uint32_t timeout_min_ms = 5000;
    std::uint32_t timeout_max_ms = 30000;
    std::size_t max_inbox = 1 << 16;              // datagrams not yet taken by receive()
    // Socket buffers. ENet's 256 KiB receive buffer holds about 2 ms of a thousand rooms'
    // inputs: a scheduling hiccup longer than that drops datagrams in the kernel. Linux caps
    // the value at net.core.rmem_max / wmem_max (docs/deployment.md).
    int socket_receive_bytes = 4 * 1024 * 1024;
    int socket_send_bytes = 1024 * 1024;
    // Several hosts behind the socket (SocketFanout above): max_connections / connections_per_host
    // hosts (rounded up), when fanout is given and connections_per_host < max_connections;
    // otherwise one host holds them all.
    SocketFanout* fanout = nullptr;
    std::size_t connections_per_host = 0;
    std::uint32_t idle_service_ms = 20;  // a host with no traffic is serviced this often (pings, resends, timeouts)
    // Unreliable sends leave at once as their own datagram (send() below), not through ENet's
    // queue and the next flush: the flush walks the host's connections and ENet allocates a
    // packet and a command per datagram, ~600 instructions per relayed datagram at 1,000 rooms
    // (docs/performance.md, "Density, third pass"). The datagram is the one ENet would send.
    // With a fanout, the other way too: a datagram that is exactly one unsequenced packet from a
    // connected peer's address and session is taken from the fanout (SocketFanout::set_claim)
    // with ENet's own checks (its unsequenced window drops repeats), so a host whose clients
    // only send inputs is serviced only for its timers (idle_service_ms).
    bool direct_unsequenced = true;
};

struct ServerConnectionEvent {
    enum class Type : std::uint8_t { Connected, Disconnected };
    Type type = Type::Connected;
    std::uint32_t connection = 0;
    std::string address;  // host:port of the client
};

// A received datagram, as a view: bytes stay valid until the next receive() or poll() (they are
// ENet's own packet buffer; copying every datagram was a measurable share of the server's cost).
struct ServerDatagram {
    std::uint32_t connection = 0;
    std::span<const std::uint8_t> bytes;
    Micros time_us = 0;
};

struct EnetServerCounters {
    std::uint64_t connections = 0;
    std::uint64_t disconnects = 0;
    std::uint64_t datagrams_in = 0, datagrams_out = 0;
    std::uint64_t dropped_oversized = 0, dropped_bad_channel = 0, dropped_inbox_full = 0;
    std::uint64_t send_failures = 0, service_errors = 0;
    // ENet's walks: enet_host_service calls (each walks its host's slots twice), enet_host_flush
    // calls (once), and the services of hosts that had no traffic for idle_service_ms.
    std::uint64_t host_services = 0, host_flushes = 0, idle_services = 0;
    std::uint64_t datagrams_direct = 0;  // unreliable sends written to the socket at once (direct_unsequenced)
    std::uint64_t datagrams_in_direct = 0, repeats_direct = 0;  // unsequenced datagrams taken from the fanout; repeats dropped
    // Half-open ENet peers reset because their client connected again from the same address and
    // client slot (SocketFanout::set_abandon across hosts; transport/enet_handshakes.h within one).
    std::uint64_t handshakes_abandoned = 0;
};

class EnetServer {
public:
    // Throws std::runtime_error naming host:port when it cannot bind, std::invalid_argument for
    // limits that cannot work.
    explicit EnetServer(const EnetServerConfig& config);
    ~EnetServer();
    EnetServer(const EnetServer&) = delete;
    EnetServer& operator=(const EnetServer&) = delete;

    std::uint16_t port() const { return port_; }
    // The host's UDP socket (lockroll-server batches its syscalls: server/enet_socket_batching.h).
    int socket_fd() const;
    // Waits up to wait_us for traffic, then takes everything ENet has (bounded per call).
    void poll(Micros now, std::uint32_t wait_us);
    bool next_event(ServerConnectionEvent& out);
    // The next datagram (see ServerDatagram: a view valid until the next receive() or poll()).
    bool receive(ServerDatagram& out);
    // Queues a datagram (sent by the next flush() or poll()); false when the connection is gone.
    // Unreliable ones, with config.direct_unsequenced, go to the socket at once instead (through
    // enet_socket_send: lockroll-server's batch holds them until its flush), as the unsequenced
    // datagram ENet itself would send, when the connection is up and the datagram fits its MTU;
    // otherwise they are queued in ENet as before.
    bool send(std::uint32_t connection, std::span<const std::uint8_t> bytes, bool reliable);
    void flush();
    // Closes a connection after what is queued for it (a kick); a Disconnected event follows.
    void disconnect(std::uint32_t connection);
    std::size_t connection_count() const { return by_id_.size(); }
    // ENet hosts behind the socket (1 unless the fanout took it), and why not when it did not.
    std::size_t host_count() const { return hosts_.size(); }
    const std::string& fanout_refused() const { return fanout_why_; }
    const EnetServerCounters& counters() const { return counters_; }
    std::uint64_t wire_bytes_sent() const;
    std::uint64_t wire_bytes_received() const;

    // Called by ENet for every datagram a host reads, before it parses it (ENetHost::intercept);
    // public only so the callback can reach it. Applies the handshake rules of
    // transport/enet_handshakes.h to connects; returns 0 (ENet handles every datagram).
    int intercept(_ENetHost* host);

private:
    void handle(const _ENetEvent& e, std::size_t host, Micros now);
    void service(std::size_t host, Micros now, std::uint32_t wait_ms, int& handled);
    void mark_dirty(std::size_t host);
    bool send_unsequenced_now(_ENetPeer* peer, std::span<const std::uint8_t> bytes);
    static bool claim_thunk(void* self, std::size_t host, std::uint32_t ip, std::uint16_t port, std::span<const std::uint8_t> d);
    bool claim(std::size_t host, std::uint32_t ip, std::uint16_t port, std::span<const std::uint8_t> d);
    static void abandon_thunk(void* self, std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id);
    void abandon(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id);
    // A received packet's bytes (from ENet's packet, or taken from the fanout) into the inbox.
    void deliver(_ENetPeer* peer, std::uint8_t channel, std::span<const std::uint8_t> bytes, _ENetPacket* packet, Micros now);
    Micros poll_now_ = 0;
    bool events_left_ = false;  // the last poll stopped at its event cap: ENet still holds some
    void release_taken();

    struct Received {
        std::uint32_t connection = 0;
        _ENetPacket* packet = nullptr;  // nullptr: bytes are the fanout's (valid until its next receive)
        Micros time_us = 0;
        std::span<const std::uint8_t> bytes;
    };

    EnetServerConfig config_;
    std::vector<_ENetHost*> hosts_;  // [0] owns the bound socket; the others share it (fanout)
    SocketFanout* fanout_ = nullptr;   // set when several hosts share the socket
    std::string fanout_why_;
    std::vector<std::uint8_t> dirty_;  // per host: sent to since it was last serviced or flushed
    std::vector<std::size_t> dirty_list_, ready_;
    std::vector<Micros> serviced_at_;
    Micros next_idle_scan_ = 0;
    std::uint16_t port_ = 0;
    std::uint32_t next_id_ = 1;
    struct Connection {
        _ENetPeer* peer = nullptr;
        std::size_t host = 0;
        std::uint32_t connect_id = 0;  // ENet resets the peer's before its disconnect event
    };
    std::unordered_map<std::uint32_t, Connection> by_id_;
    std::deque<ServerConnectionEvent> events_;
    std::vector<Received> inbox_;  // [inbox_next_, size) not yet taken; taken ones are destroyed
    std::size_t inbox_next_ = 0;     // by the next receive() or poll()
    EnetServerCounters counters_;
};

}  // namespace lockroll::transport
